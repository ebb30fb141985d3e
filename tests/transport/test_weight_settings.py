"""Weights set without code: a put on a follower's weight key moves the weight the
leader polls by; a bad value or an unknown follower is counted with its key and the
old weight stays."""

from __future__ import annotations

import pytest
import zenoh

from wiswarm_zenoh.transport import FollowerNode, LeaderNode
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.weight_settings import parse_weight

from .helpers import Recorder, Sessions, eventually

SWARM = "wt"
KEYS = SwarmKeys(SWARM)


def _weight(leader: LeaderNode, follower: str) -> float | None:
    return next((s.weight for s in leader.latest if s.follower == follower), None)


def test_a_put_on_the_weight_key_sets_the_weight_and_bad_ones_keep_it(
        sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder) -> None:
    tool = sessions.node(port)
    follower = FollowerNode(sessions.node(port), SWARM, "uav1")  # held: its token stays
    follower.offer(b"x")
    with LeaderNode(sessions.node(port), SWARM, every_record=True,
                    **recorder.callbacks()) as leader:
        recorder.wait("join", lambda r: r.joins == ["uav1"])
        eventually("first stats", lambda: _weight(leader, "uav1") == 1.0)
        tool.put(KEYS.weight("uav1"), "4")
        eventually("weight 4", lambda: _weight(leader, "uav1") == 4.0)
        for bad in ("-1", "nan", "four", "1e999"):
            tool.put(KEYS.weight("uav1"), bad)
        tool.put(KEYS.weight("uav9"), "2")  # no such follower
        eventually("five refused", lambda: leader.bad_input.total() == 5)
        assert set(leader.bad_input.counts) == {KEYS.weight("uav1"), KEYS.weight("uav9")}
        tool.put(KEYS.weight("uav1"), "0.5")  # after the bad ones: still heard
        eventually("weight 0.5", lambda: _weight(leader, "uav1") == 0.5)


@pytest.mark.parametrize("text,weight", [(b"4", 4.0), (b" 0.25\n", 0.25), (b"0", 0.0)])
def test_weights_are_decimal_text(text: bytes, weight: float) -> None:
    assert parse_weight(text) == weight


@pytest.mark.parametrize("text", [b"-1", b"inf", b"nan", b"", b"\xff", b"1" * 65])
def test_what_is_not_a_weight_says_why(text: bytes) -> None:
    with pytest.raises(ValueError, match="weight"):
        parse_weight(text)
