"""UAV-side waypoint checks: unsafe plans are rejected with a reason, the last one holds."""

from __future__ import annotations

import logging
import math

import pytest

from wiswarm_apps.tracking.geometry import Arena
from wiswarm_apps.tracking.waypoints import WaypointError, WaypointGuard, check_waypoints

ARENA = Arena()
GOOD = [(1.0, 2.0, 3.0, 2.0), (1.1, 2.1, 3.0, 2.0)]


@pytest.mark.parametrize(
    ("plan", "reason"),
    [
        ([], "1..256"),
        ([(1.0, math.nan, 3.0, 2.0)], "not finite"),
        ([(math.inf, 1.0, 3.0, 2.0)], "not finite"),
        ([(1.0, 25.0, 3.0, 2.0)], "outside the 20.0 x 10.0 m arena"),
        ([(1.0, 2.0, -0.1, 2.0)], "outside"),
        ([(1.0, 2.0, 3.0, 0.0)], "altitude"),
        ([(1.0, 2.0, 3.0, 11.0)], "altitude"),
        ([(1.0, 2.0, 3.0)], r"\(t, x, y, z\)"),
        ([(1.0, "a", 3.0, 2.0)], "not numeric"),
        ([(2.0, 2.0, 3.0, 2.0), (1.0, 2.0, 3.0, 2.0)], "earlier"),
    ],
)
def test_unsafe_plans_are_rejected_with_the_reason(plan: list[tuple[object, ...]],
                                                   reason: str) -> None:
    with pytest.raises(WaypointError, match=reason):
        check_waypoints(plan, ARENA)  # type: ignore[arg-type]


def test_guard_holds_the_last_safe_plan_and_logs_why(caplog: pytest.LogCaptureFixture) -> None:
    guard = WaypointGuard(ARENA, "uav-7")
    assert guard.offer(GOOD)
    with caplog.at_level(logging.WARNING):
        assert not guard.offer([(2.0, math.nan, 1.0, 2.0)])
    assert guard.plan == tuple(GOOD)
    assert (guard.accepted, guard.rejected) == (1, 1)
    assert guard.last_reason is not None and "not finite" in guard.last_reason
    assert "uav-7" in caplog.text and "not finite" in caplog.text


def test_due_next_is_the_first_future_waypoint_then_the_last() -> None:
    guard = WaypointGuard(ARENA)
    assert guard.due_next(0.0) is None
    guard.offer(GOOD)
    assert guard.due_next(0.5) == GOOD[0]
    assert guard.due_next(1.0) == GOOD[1]
    assert guard.due_next(9.0) == GOOD[1]
