"""The leader's control information: each follower's latest waypoints, packed once while
they do not change, and when they go out with a poll (at once after a change, else every
``control_period``).

A leader whose followers are sites' (a cloud's ``<site>.<follower>``, joined with their
site as ``link``) sends each site a message of its own, with that site's entries only:
no site hears where another's robots are sent. Followers of no site share one message,
as every follower of a single swarm does."""

from __future__ import annotations

import math
from collections.abc import Sequence

from wiswarm_zenoh.core.wire import Waypoint, pack_entries, validate_waypoints

Site = str | None  # a follower's site (its link); None: of none


class ControlSchedule:
    """Waypoints per follower and the broadcast's schedule (no I/O: ``now`` comes in)."""

    def __init__(self, period: float) -> None:
        self.period = period
        self.seq = 0  # of the last control sent
        self.waypoints: dict[str, list[Waypoint]] = {}
        self._sites: dict[str, Site] = {}  # each member's site
        self._packed: dict[Site, bytes] | None = None  # cache of the packed entries
        self._due = True  # changed since last sent: goes with the next poll
        self._sent_at = -math.inf

    def set(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        """A follower's latest waypoints (ValueError for any no follower may be sent)."""
        self.waypoints[follower] = validate_waypoints(waypoints)
        self.changed()

    def join(self, follower: str, site: Site) -> None:
        """A follower joined, of ``site``: it needs the control now."""
        self._sites[follower] = site
        self.changed()

    def drop(self, follower: str) -> None:
        """A follower left: its waypoints go."""
        self._sites.pop(follower, None)
        self.waypoints.pop(follower, None)
        self._packed = None

    def changed(self) -> None:
        """Send the control with the next poll (new waypoints, a newcomer, a new epoch)."""
        self._packed = None
        self._due = True

    def take(self, now: float) -> dict[Site, bytes] | None:
        """The packed entries to send with a poll at ``now``, by site (None: the
        followers of no site, every follower of a single swarm), or None if not due."""
        if not self._due and now - self._sent_at < self.period:
            return None
        if self._packed is None:
            self._packed = self._pack()
        self._due, self._sent_at = False, now
        self.seq += 1
        return self._packed

    def _pack(self) -> dict[Site, bytes]:
        """Each site's entries (a site with no waypoints yet gets its empty message: its
        followers learn the leader's epoch from it); those of no site while any
        follower is of none, or no follower of a site is there."""
        by_site: dict[Site, dict[str, list[Waypoint]]] = {
            site: {} for site in self._sites.values()}
        if None not in by_site and not by_site:
            by_site[None] = {}
        for follower, waypoints in self.waypoints.items():
            by_site.setdefault(self._sites.get(follower), {})[follower] = waypoints
        return {site: pack_entries(entries) for site, entries in by_site.items()}
