"""A secured swarm and a robot serving several streams: its members ``<id>~<stream>``
are its own to serve and to hold tokens for, under its one certificate; another
follower can neither answer for them nor say it is one of them."""

from __future__ import annotations

import zenoh

from wiswarm_zenoh.transport.keys import stream_member

from .helpers import KEYS, Sessions, answer, flushed, replies, until


def members(leader: zenoh.Session) -> set[str]:
    return {str(reply.ok.key_expr) for reply in leader.liveliness().get(KEYS.members,
                                                                        timeout=2.0)
            if reply.ok is not None}


def test_a_robots_streams_are_its_own(sessions: Sessions, router: zenoh.Session) -> None:
    leader, f1, f2 = (sessions.open(name) for name in ("leader", "f1", "f2"))
    camera, odometry = stream_member("f1", "camera"), stream_member("f1", "odometry")
    held = [f1.liveliness().declare_token(KEYS.member(camera)),
            f2.liveliness().declare_token(KEYS.member(odometry))]  # f2 posing as f1's
    served = [answer(f1, KEYS.update(camera), b"f1 camera"),
              answer(f2, KEYS.update(odometry), b"f2 posing as f1's odometry"),
              answer(f2, KEYS.update("f2"), b"ack")]
    flushed(leader, "f2")  # f2's token and queryable were taken or refused by now
    try:
        until("f1's camera answers", lambda: replies(leader, KEYS.update(camera), 1.0) ==
              [b"f1 camera"])
        assert members(leader) == {KEYS.member(camera)}
        assert replies(leader, KEYS.update(odometry), timeout=1.0) == []
    finally:
        for entity in [*held, *served]:
            entity.undeclare()
