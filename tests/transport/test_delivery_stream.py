"""``wiswarm/<swarm>/leader/deliveries``: every delivery and unanswered poll, batched,
and nothing gathered while nobody listens. Real sessions on loopback."""

from __future__ import annotations

import json
from typing import Any

import zenoh

from wiswarm_zenoh.core import Delivered, LeaderConfig, TimedOut
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SwarmKeys
from wiswarm_zenoh.transport.delivery_stream import DeliveryStream

from .helpers import Recorder, Samples, Sessions, eventually, wait_until_known

SWARM = "stream"
KEY = f"wiswarm/{SWARM}/leader/deliveries"


def _records(samples: Samples) -> list[dict[str, Any]]:
    with samples.cond:
        return [r for s in samples.samples for r in json.loads(s.payload.to_bytes())]


def test_deliveries_and_unanswered_polls_reach_a_subscriber_in_batches(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    held: list[zenoh.Query] = []  # a member that never answers: its polls time out
    mute = sessions.node(port)
    queryable = mute.declare_queryable(f"wiswarm/{SWARM}/mute/update", held.append)
    token = mute.liveliness().declare_token(f"wiswarm/{SWARM}/members/mute")  # kept: alive
    FollowerNode(sessions.node(port), SWARM, "f1", sample_on_poll=lambda: b"frame")
    stream = Samples(sessions.node(port), KEY)
    with LeaderNode(sessions.node(port), SWARM, LeaderConfig(timeout=0.05),
                    **recorder.callbacks()):
        stream.wait("deliveries and timeouts on the stream", lambda s: {
            (r["follower"], r["outcome"]) for r in _records(s)
        } >= {("f1", "delivered"), ("mute", "timeout")})
        recorder.wait("100 deliveries", lambda r: len(r.deliveries) >= 100)
    token.undeclare()
    queryable.undeclare()
    records = _records(stream)
    for record in records:
        assert set(record) == {"follower", "outcome", "generated_at", "delivered_at"}
        if record["outcome"] == "delivered":
            assert record["follower"] == "f1"
            assert record["generated_at"] <= record["delivered_at"]
        else:
            assert record["generated_at"] is None  # (f1 too may miss an adaptive deadline)
    # The stream's deliveries are the leader's own, in order.
    delivered = [(r["generated_at"], r["delivered_at"]) for r in records
                 if r["outcome"] == "delivered"]
    own = [(d.generated_at, d.delivered_at) for d in recorder.deliveries]
    assert delivered and delivered == own[own.index(delivered[0]):][:len(delivered)]
    with stream.cond:
        assert len(stream.samples) < len(records) / 3  # batched, not a put per event


def test_nothing_is_gathered_while_nobody_listens(sessions: Sessions, router: zenoh.Session,
                                                  port: int) -> None:
    leader = sessions.node(port)
    stream = DeliveryStream(leader, SwarmKeys(SWARM))
    try:
        unheard = Delivered("f1", b"", generated_at=1.0, delivered_at=2.0, update_seq=1)
        stream.add(unheard, 2.0)
        assert stream.due == float("inf")  # nothing gathered, nothing to wake up for
        listener = Samples(sessions.node(port), KEY)
        wait_until_known(leader, KEY)
        # The stream's own matching listener may be called later than the one above.
        eventually("the stream hears of its subscriber", lambda: stream.listening)
        stream.add(TimedOut("f2", poll_seq=7), 3.0)
        assert stream.due == 3.0 + 0.1
        stream.flush()
        listener.wait("the batch", lambda s: bool(s.samples))
        assert _records(listener) == [{"follower": "f2", "outcome": "timeout",
                                       "generated_at": None, "delivered_at": 3.0}]
    finally:
        stream.close()
