"""Weights given before members join (``wiswarm leader --weight``): each member takes
its preset when it joins, and again when it comes back, whatever was set meanwhile."""

from __future__ import annotations

import math

import pytest

from wiswarm_zenoh.core import Leader

from .drive import poll


def _weight(leader: Leader, follower: str) -> float:
    return leader.stats(follower, 0.0).weight


def test_a_preset_is_taken_at_join_and_again_at_a_return() -> None:
    leader = Leader()
    leader.preset_weight("b", 4.0)
    assert leader.members.never_joined == ["b"]
    leader.add_follower("a", 0.0)
    leader.add_follower("b", 0.0)
    assert (_weight(leader, "a"), _weight(leader, "b")) == (1.0, 4.0)
    assert leader.members.never_joined == []
    assert poll(leader, 0.1).follower == "b"  # equal ages: the heavier first
    leader.set_weight("b", 0.5)  # a live setting holds while it stays
    assert _weight(leader, "b") == 0.5
    leader.remove_follower("b", 1.0)
    assert leader.stats("b", 1.0).weight == 0.5  # departed: as it was
    leader.add_follower("b", 2.0)
    assert _weight(leader, "b") == 4.0


def test_a_preset_for_a_member_present_applies_at_once() -> None:
    leader = Leader()
    leader.add_follower("a", 0.0)
    leader.preset_weight("a", 2.5)
    assert _weight(leader, "a") == 2.5
    leader.observe_urgency("a", 0.0)  # the application's urgency goes on from it
    assert _weight(leader, "a") < 2.5


@pytest.mark.parametrize("weight", [-1.0, math.nan, math.inf])
def test_what_is_not_a_weight_is_never_preset(weight: float) -> None:
    leader = Leader()
    with pytest.raises(ValueError, match="weight"):
        leader.preset_weight("a", weight)
    leader.add_follower("a", 0.0)
    assert _weight(leader, "a") == 1.0
