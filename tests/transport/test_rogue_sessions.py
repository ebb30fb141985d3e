"""A stranger's session on an open swarm, as reported: forged control, replies forged on
a follower's key, a second poller. Real sessions on loopback; the protocol holds."""

from __future__ import annotations

import threading
import time

import zenoh

from wiswarm_zenoh.core import Waypoint
from wiswarm_zenoh.core.wire import (
    Control,
    FragmentData,
    Poll,
    Reply,
    checksum,
    decode_poll,
    decode_reply,
    encode_control,
    encode_poll,
    encode_reply,
)
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

from .helpers import WAIT, Recorder, Sessions

SWARM = "rogue"
HOUR = 3600.0


def test_control_stamped_an_hour_ahead_is_refused_and_the_leader_keeps_steering(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    obeyed: list[list[Waypoint]] = []
    changed = threading.Condition()

    def on_control(entry: list[Waypoint]) -> None:
        with changed:
            obeyed.append(entry)
            changed.notify_all()

    follower = FollowerNode(sessions.node(port), SWARM, "uav1", on_control=on_control)
    session = sessions.node(port)
    with LeaderNode(session, SWARM, **recorder.callbacks()) as leader:
        follower.offer(b"first")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 1)  # polled: clock known
        forged = Control(1, time.time() + HOUR, {"uav1": [(0.0, 66.0, 66.0, 66.0)]},
                         leader.epoch)  # a stranger can read the epoch off control
        # Put on the leader's session only so that it arrives before the leader's next
        # control (same session, same link): which session sends it changes nothing.
        session.put(f"wiswarm/{SWARM}/control", encode_control(forged), express=True)
        for k in (1.0, 2.0):
            leader.set_control("uav1", [(k, k, k, k)])
            with changed:
                assert changed.wait_for(lambda k=k: obeyed and obeyed[-1][0][0] == k, WAIT)
    assert all(entry[0][1] != 66.0 for entry in obeyed)
    assert follower.bad_input.counts[f"wiswarm/{SWARM}/control"] == 1


def _forger(session: zenoh.Session, key: str, answered: list[float]) -> zenoh.Queryable[None]:
    """A queryable on a follower's key that answers each poll with a well-formed update
    stamped an hour ahead (its clock stamps too, as a consistent clock would)."""

    def on_query(query: zenoh.Query) -> None:
        with query:
            payload = query.payload
            poll = decode_poll(b"" if payload is None else payload.to_bytes())
            now = time.time() + HOUR
            frag = FragmentData(10**9, now, 0, 1, 5, checksum(b"rogue"), b"rogue")
            query.reply(key, encode_reply(Reply("uav1", poll.seq, now, now, frag)))
            answered.append(now)

    return session.declare_queryable(key, on_query)


def test_replies_forged_an_hour_ahead_never_cut_the_follower_off(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    key = f"wiswarm/{SWARM}/uav1/update"
    counter = iter(range(10**9))
    FollowerNode(sessions.node(port), SWARM, "uav1",
                 sample_on_poll=lambda: b"frame %d" % next(counter))
    answered: list[float] = []
    with LeaderNode(sessions.node(port), SWARM, **recorder.callbacks()) as leader:
        recorder.wait("first deliveries", lambda r: r.count("uav1") >= 5)
        forger = _forger(sessions.node(port), key, answered)
        recorder.wait("deliveries beside the forger",
                      lambda r: r.count("uav1") >= 60 and len(answered) >= 20)
        forger.undeclare()
        after = recorder.count("uav1")
        recorder.wait("deliveries after it", lambda r: r.count("uav1") >= after + 20)
        assert leader.bad_input.counts[key] >= 1
    assert all(d.payload != b"rogue" for d in recorder.deliveries)
    assert all(0.0 <= d.age < 1.0 for d in recorder.deliveries)


def test_a_second_poller_takes_no_frame_from_the_leader(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    """Each frame offered reaches the leader, while a stranger polls the follower as fast
    as it can, with a higher epoch than the leader's (it would be the one to take the
    queue) and then a lower one."""
    follower = FollowerNode(sessions.node(port), SWARM, "uav1")
    stranger = sessions.node(port)
    stop = threading.Event()
    got: list[int] = []

    def poll_forever(epoch: int) -> None:
        seq = 0
        while not stop.is_set():
            seq += 1
            poll = Poll(seq, time.time(), None, "next", epoch)
            for reply in stranger.get(f"wiswarm/{SWARM}/uav1/update",
                                      payload=encode_poll(poll), timeout=WAIT):
                if reply.ok is not None:
                    got.append(seq)
                    decode_reply(reply.ok.payload.to_bytes())

    with LeaderNode(sessions.node(port), SWARM, **recorder.callbacks()) as leader:
        for epoch in (leader.epoch + 1, 5):
            thread = threading.Thread(target=poll_forever, args=(epoch,), daemon=True)
            thread.start()
            try:
                for k in range(20):
                    frame = b"frame %d at epoch %d" % (k, epoch)
                    follower.offer(frame)
                    recorder.wait(f"{frame!r} delivered",
                                  lambda r, f=frame: any(d.payload == f for d in r.deliveries))
            finally:
                stop.set()
                thread.join()
                stop.clear()
    assert len(got) >= 20  # the stranger was answered all along
