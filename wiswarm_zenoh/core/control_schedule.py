"""The leader's control information: each follower's latest waypoints, packed once while
they do not change, and when they go out with a poll (at once after a change, else every
``control_period``)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from wiswarm_zenoh.core.wire import Waypoint, pack_entries, validate_waypoints


class ControlSchedule:
    """Waypoints per follower and the broadcast's schedule (no I/O: ``now`` comes in)."""

    def __init__(self, period: float) -> None:
        self.period = period
        self.seq = 0  # of the last control sent
        self.waypoints: dict[str, list[Waypoint]] = {}
        self._packed: bytes | None = None  # cache of the packed entries
        self._due = True  # changed since last sent: goes with the next poll
        self._sent_at = -math.inf

    def set(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        """A follower's latest waypoints (ValueError for any no follower may be sent)."""
        self.waypoints[follower] = validate_waypoints(waypoints)
        self.changed()

    def drop(self, follower: str) -> None:
        """A follower left: its waypoints go."""
        if self.waypoints.pop(follower, None) is not None:
            self._packed = None

    def changed(self) -> None:
        """Send the control with the next poll (new waypoints, a newcomer, a new epoch)."""
        self._packed = None
        self._due = True

    def take(self, now: float) -> bytes | None:
        """The packed entries to send with a poll at ``now``, or None if not due."""
        if not self._due and now - self._sent_at < self.period:
            return None
        if self._packed is None:
            self._packed = pack_entries(self.waypoints)
        self._due, self._sent_at = False, now
        self.seq += 1
        return self._packed
