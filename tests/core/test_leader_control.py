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


def test_each_site_gets_a_control_of_its_own_entries_only() -> None:
    """A cloud's followers are its sites' (joined with their site as link): each site's
    message holds its followers' waypoints only, those of no site go on the plain key,
    and a site with no waypoints yet still gets its (empty) message, for the epoch."""
    leader = Leader()
    for follower, site in (("s1.a", "s1"), ("s1.b", "s1"), ("s2.c", "s2"), ("s3.d", "s3")):
        leader.add_follower(follower, 0.0, link=site)
    leader.set_control("s1.a", [(1.0, 1.0, 1.0, 1.0)])
    leader.set_control("s2.c", [(2.0, 2.0, 2.0, 2.0)])
    first = poll(leader, 1.0)
    controls = first.controls
    assert controls is not None
    entries = {site: decode_control(message).entries for site, message in controls.items()}
    assert entries == {"s1": {"s1.a": [(1.0, 1.0, 1.0, 1.0)]},
                       "s2": {"s2.c": [(2.0, 2.0, 2.0, 2.0)]}, "s3": {}}
    on_timer(leader, first.deadline)
    leader.add_follower("plain", first.deadline)
    leader.remove_follower("s3.d", first.deadline)
    controls = poll(leader, first.deadline).controls
    assert controls is not None and set(controls) == {None, "s1", "s2"}
    assert decode_control(controls[None]).entries == {}
