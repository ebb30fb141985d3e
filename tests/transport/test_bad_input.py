"""Rogue peers: garbage, impostors, oversized and error replies, bad keys, bad control."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import pytest
import zenoh

from wiswarm_zenoh.core import LeaderConfig
from wiswarm_zenoh.core.wire import Reply, decode_poll, encode_reply
from wiswarm_zenoh.programs.frames import SyntheticFrames
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

from .helpers import WAIT, Recorder, Samples, Sessions

SWARM = "b"


def _rogue(session: zenoh.Session, name: str,
           answer: Callable[[zenoh.Query, str], object]) -> list[object]:
    """A member whose queryable answers every poll with ``answer(query, key)``."""
    key = f"wiswarm/{SWARM}/{name}/update"

    def on_query(query: zenoh.Query) -> None:
        with query:
            answer(query, key)

    return [session.declare_queryable(key, on_query),
            session.liveliness().declare_token(f"wiswarm/{SWARM}/members/{name}")]


def _impostor(query: zenoh.Query, key: str) -> None:
    payload = query.payload
    poll = decode_poll(b"" if payload is None else payload.to_bytes())
    query.reply(key, encode_reply(Reply("someone-else", poll.seq, time.time(), time.time(), None)))


def test_rogue_replies_are_counted_and_logged_and_the_others_still_served(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder,
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.WARNING, logger="wiswarm_zenoh")
    real = [FollowerNode(sessions.node(port), SWARM, name) for name in ("uav1", "uav2")]
    sources = [SyntheticFrames(node.offer, size=1000, rate=100.0) for node in real]
    rogues = sessions.node(port)
    held = [
        *_rogue(rogues, "garbage", lambda q, k: q.reply(k, b"\x00 not msgpack")),
        *_rogue(rogues, "impostor", _impostor),
        *_rogue(rogues, "big", lambda q, k: q.reply(k, bytes(20_000))),
        *_rogue(rogues, "failing", lambda q, k: q.reply_err(b"no frame for you")),
        # A second queryable on a real follower's key: it cannot hide the real one.
        rogues.declare_queryable(f"wiswarm/{SWARM}/uav1/update",
                                 lambda q: (q.reply(q.key_expr, b"junk"), q.drop())),
        rogues.liveliness().declare_token(f"wiswarm/{SWARM}/members/leader"),  # reserved
    ]
    watch = Samples(sessions.node(port), f"wiswarm/{SWARM}/*/stats")
    bad = ("garbage", "impostor", "big", "failing")

    def errors(w: Samples, name: str) -> int:
        found = w.stats(f"wiswarm/{SWARM}/{name}/stats")
        return int(found[-1]["errors"]) if found else 0

    config = LeaderConfig(max_update_bytes=10_000)
    with LeaderNode(sessions.node(port), SWARM, config, stats_period=0.1,
                    **recorder.callbacks()) as leader:
        for source in sources:
            source.start()
        try:
            watch.wait("errors counted", lambda w: all(errors(w, n) >= 3 for n in bad)
                       and errors(w, "uav1") >= 3)
            recorder.wait("real followers served",
                          lambda r: r.count("uav1") >= 10 and r.count("uav2") >= 10)
        finally:
            for source in sources:
                source.stop()
        assert sorted(leader.followers) == ["big", "failing", "garbage", "impostor", "uav1",
                                            "uav2"]
        counted = dict(leader.bad_input.counts)
    for name in (*bad, "uav1"):
        key = f"wiswarm/{SWARM}/{name}/update"
        assert counted[key] >= 3
        assert f"bad input from {key}" in caplog.text
    assert counted[f"wiswarm/{SWARM}/members/leader"] == 1
    assert errors(watch, "uav2") == 0
    del held


def test_a_follower_shrugs_off_garbage_polls_and_control(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    obeyed = threading.Event()
    follower = FollowerNode(sessions.node(port), SWARM, "uav1",
                            on_control=lambda entry: obeyed.set())
    session = sessions.node(port)
    with LeaderNode(session, SWARM, **recorder.callbacks()) as leader:
        follower.offer(b"first")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 1)  # routes are up
        replies = list(session.get(f"wiswarm/{SWARM}/uav1/update", payload=b"junk",
                                   timeout=WAIT))
        # Sent before the leader's next control put, on the same session and link.
        session.put(f"wiswarm/{SWARM}/control", b"junk", express=True)
        leader.set_control("uav1", [(0.0, 1.0, 1.0, 1.0)])
        assert obeyed.wait(WAIT)
        follower.offer(b"still fine")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 2)
    assert all(r.ok is None for r in replies)  # no answer to garbage, just the query's end
    assert follower.bad_input.counts[f"wiswarm/{SWARM}/uav1/update"] == 1
    assert follower.bad_input.counts[f"wiswarm/{SWARM}/control"] == 1


def test_a_follower_of_another_swarm_is_not_polled(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    stranger = FollowerNode(sessions.node(port), "elsewhere", "uav9")
    ours = FollowerNode(sessions.node(port), SWARM, "uav1")
    with LeaderNode(sessions.node(port), SWARM, **recorder.callbacks()) as leader:
        ours.offer(b"x")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 1)
        assert leader.followers == ["uav1"]
    assert stranger.polls == 0
    assert recorder.joins == ["uav1"]


def test_a_slow_second_queryable_neither_holds_up_polling_nor_goes_uncounted(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    """The poll is over at the follower's valid reply; the get stays open aside for the
    slow one, whose late junk is still counted against the key (as long as it comes
    before the get's timeout: the follower's own, from its answers, at least 10 ms)."""
    slow_s = 0.003  # each answer 3 ms after its query: well after the follower's

    def reply_later(query: zenoh.Query) -> None:
        with query:
            query.reply(query.key_expr, b"junk")

    def slow(query: zenoh.Query) -> None:
        # Answered from a timer, not by sleeping here: every query gets its answer
        # slow_s later, instead of a backlog that would reach each get after it closed.
        threading.Timer(slow_s, reply_later, args=(query,)).start()

    follower = FollowerNode(sessions.node(port), SWARM, "uav1", sample_on_poll=lambda: b"f")
    held = sessions.node(port).declare_queryable(f"wiswarm/{SWARM}/uav1/update", slow)
    watch = Samples(sessions.node(port), f"wiswarm/{SWARM}/uav1/stats")
    with LeaderNode(sessions.node(port), SWARM, stats_period=0.1, **recorder.callbacks()):
        recorder.wait("deliveries", lambda r: r.count("uav1") >= 10)
        # Waiting for each get to close would allow one delivery per timeout (>= 10 ms).
        first = recorder.deliveries[0]
        tenth = [d for d in recorder.deliveries if d.follower == "uav1"][9]
        span = (tenth.generated_at + tenth.age) - (first.generated_at + first.age)
        assert span < 9 * LeaderConfig().timeout_floor
        # Ten polls can be over before the first junk is 3 ms old: wait for its count.
        watch.wait("late junk counted", lambda w: any(
            int(s["errors"]) >= 1 for s in w.stats(f"wiswarm/{SWARM}/uav1/stats")))
    assert follower.polls >= 10
    del held
