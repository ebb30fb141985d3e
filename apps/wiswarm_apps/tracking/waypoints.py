"""Waypoint plans on the UAV side: validation and the last safe plan.

A plan arrives from the network; if any waypoint is NaN, outside the arena or out of
time order, the whole plan is rejected with a logged reason and the UAV keeps flying
the last plan that passed (its last safe waypoint). Times are in the UAV's clock.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Sequence

from wiswarm_apps.tracking.geometry import Arena
from wiswarm_zenoh.core import MAX_WAYPOINTS, Waypoint

log = logging.getLogger(__name__)


class WaypointError(ValueError):
    """A plan that must not be flown (the message says why)."""


def check_waypoints(waypoints: Sequence[Sequence[float]], arena: Arena) -> list[Waypoint]:
    """Return the plan as float tuples, or raise WaypointError naming the first fault."""
    if not 1 <= len(waypoints) <= MAX_WAYPOINTS:
        raise WaypointError(f"plan must have 1..{MAX_WAYPOINTS} waypoints, got {len(waypoints)}")
    plan: list[Waypoint] = []
    for i, waypoint in enumerate(waypoints):
        if len(waypoint) != 4:
            raise WaypointError(f"waypoint {i} must be (t, x, y, z), got {len(waypoint)} values")
        try:
            t, x, y, z = (float(value) for value in waypoint)
        except (TypeError, ValueError) as exc:
            raise WaypointError(f"waypoint {i} is not numeric: {exc}") from exc
        if not all(math.isfinite(value) for value in (t, x, y, z)):
            raise WaypointError(f"waypoint {i} is not finite: {(t, x, y, z)}")
        if not arena.contains(x, y):
            raise WaypointError(
                f"waypoint {i} at ({x:.3f}, {y:.3f}) is outside the "
                f"{arena.width_m} x {arena.height_m} m arena"
            )
        if not 0.0 < z <= arena.max_altitude_m:
            raise WaypointError(
                f"waypoint {i} altitude {z:.3f} is outside (0, {arena.max_altitude_m}] m"
            )
        if plan and t < plan[-1][0]:
            raise WaypointError(f"waypoint {i} at t={t} is earlier than waypoint {i - 1}")
        plan.append((t, x, y, z))
    return plan


class WaypointGuard:
    """Holds the last safe plan; thread-safe (network thread offers, flight loop reads)."""

    def __init__(self, arena: Arena, name: str = "uav") -> None:
        self.arena = arena
        self.name = name
        self.accepted = 0
        self.rejected = 0
        self.last_reason: str | None = None
        self._plan: tuple[Waypoint, ...] = ()
        self._lock = threading.Lock()

    @property
    def plan(self) -> tuple[Waypoint, ...]:
        with self._lock:
            return self._plan

    def offer(self, waypoints: Sequence[Sequence[float]]) -> bool:
        """Adopt the plan if it is safe; otherwise log why, count it, keep the old one."""
        try:
            plan = tuple(check_waypoints(waypoints, self.arena))
        except WaypointError as exc:
            with self._lock:
                self.rejected += 1
                self.last_reason = str(exc)
            log.warning("%s: rejected waypoints, holding the last safe plan: %s", self.name, exc)
            return False
        with self._lock:
            self._plan = plan
            self.accepted += 1
        return True

    def due_next(self, now: float) -> Waypoint | None:
        """The first waypoint due after `now`, else the last one (hold), else None."""
        plan = self.plan
        for waypoint in plan:
            if waypoint[0] > now:
                return waypoint
        return plan[-1] if plan else None
