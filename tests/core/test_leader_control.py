"""The control information the leader broadcasts with its polls, as followers obey it."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.core import Leader
from wiswarm_zenoh.core.wire import decode_control

from .drive import on_timer, poll
from .test_leader import _setup


def test_control_is_broadcast_with_every_poll() -> None:
    leader, followers = _setup("a", "b")
    wps = [(1.0, 2.0, 3.0, 4.0)]
    leader.set_control("a", wps)
    first = poll(leader, 1.0)
    control = decode_control(first.control)
    assert control.entries == {"a": wps}
    assert control.leader_time == 1.0
    assert followers["a"].on_control(first.control, 1.0) == wps
    assert followers["b"].on_control(first.control, 1.0) is None
    on_timer(leader, first.deadline)
    second = poll(leader, 1.2)
    assert decode_control(second.control).seq > control.seq
    assert followers["a"].on_control(first.control, 1.2) is None  # older: ignored
    assert followers["a"].on_control(second.control, 1.2) == wps
    with pytest.raises(ValueError, match="unknown follower"):
        leader.set_control("zz", wps)
    with pytest.raises(ValueError):
        leader.set_control("a", [(0.0, 0.0, 0.0)])


def test_restarted_leader_is_still_obeyed() -> None:
    leader, followers = _setup("a")
    leader.set_control("a", [(1.0, 0.0, 0.0, 0.0)])
    for k in range(5):
        followers["a"].on_control(poll(leader, float(k)).control, float(k))
        on_timer(leader, leader.get_timer() or k)
    fresh_leader = Leader(epoch=leader.epoch + 1)
    fresh_leader.add_follower("a", 10.0)
    fresh_leader.set_control("a", [(9.0, 9.0, 9.0, 9.0)])
    request = poll(fresh_leader, 10.0)
    assert decode_control(request.control).seq == 1
    assert followers["a"].on_control(request.control, 10.0) == [(9.0, 9.0, 9.0, 9.0)]


def test_a_leader_taking_over_starts_from_the_weights_and_control_it_was_given() -> None:
    leader, followers = _setup("a", "b")
    leader.take_over(leader.epoch + 5, {"a": 0.1, "b": 9.0, "gone": 3.0},
                     {"b": [(1.0, 2.0, 3.0, 4.0)], "gone": [(0.0, 0.0, 0.0, 1.0)]})
    assert leader.epoch == 5
    assert (leader.stats("a", 0.0).weight, leader.stats("b", 0.0).weight) == (0.1, 9.0)
    request = poll(leader, 1.0)
    assert request.follower == "b"  # the heavier, as the leader before would have chosen
    control = decode_control(request.control)
    assert (control.epoch, control.entries) == (5, {"b": [(1.0, 2.0, 3.0, 4.0)]})
    assert followers["b"].on_control(request.control, 1.0) == [(1.0, 2.0, 3.0, 4.0)]
    with pytest.raises(ValueError, match="epoch"):
        leader.take_over(-1, {}, {})
