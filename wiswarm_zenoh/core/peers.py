"""The followers' figures that the policies read, in columns kept in step by themselves.

Per-follower objects (``peer.Peer``) hold the estimators; the numbers the policy reads
(w, p, tau, ...) are mirrored in columns of doubles that a plain loop reads as floats (a
few followers) and numpy views without a copy (thousands: one vectorised pass). Each
peer tells its table when it changed, so no caller keeps the two in step by hand.
"""

from __future__ import annotations

import math
from array import array

import numpy as np
import numpy.typing as npt

from wiswarm_zenoh.core.aoi import FloatArray
from wiswarm_zenoh.core.follower_stats import FollowerStats
from wiswarm_zenoh.core.peer import Peer, unwatched
from wiswarm_zenoh.core.poll_timing import SwarmPollTimes

__all__ = ["FollowerStats", "IntArray", "Peer", "PeerTable"]

IntArray = npt.NDArray[np.intp]


PLAIN_LOOPS_MAX = 64  # followers up to which plain loops beat numpy (its cost per call
# is fixed)


class PeerTable:
    """Followers in join order, with the columns (w, p, tau, due, interval, ready,
    probe_at) the leader reads.

    ``w`` is each follower's weight raised to ``weight_floor`` (with ``price_by_time``,
    per unit of its polls' expected time: ``PollTiming.price``); ``tau`` its
    freshest delivery (for a source taken as always fresh, its last "nothing new" answer
    too: polling it sooner cannot lower its age); ``due``, ``interval`` and ``ready`` its
    source's pace (``sources``: -inf and 0 for a source taken as always fresh, +inf for a
    silent follower, whose probes ``probe_at`` times: when it is due for one, +inf if
    not silent; ``ready`` is a phased source's, ``tau`` for any other); ``silent``
    counts those with p = 0 and ``unfresh`` and ``known_intervals`` those whose due is not -inf
    or whose interval is known, so that the common case (none) costs the scheduler no
    pass over the columns.
    """

    def __init__(self, weight_floor: float = 0.0, price_by_time: bool = False,
                 pace_sources: bool = True) -> None:
        self.weight_floor = weight_floor
        self.price_by_time = price_by_time
        self.pace_sources = pace_sources
        self.poll_times = SwarmPollTimes()  # every follower's answered polls
        self.ids: list[str] = []
        self.peers: dict[str, Peer] = {}
        self.silent = 0
        self.unfresh = 0  # followers whose due is not -inf (paced, phased or silent)
        self.known_intervals = 0  # followers whose interval column is known (paced or phased)
        self._index: dict[str, int] = {}
        self._watched = -1  # the row whose changes leave ``disturbed`` as it is
        self.disturbed = True
        self.w = array("d")
        self.p = array("d")
        self.tau = array("d")
        self.due = array("d")
        self.interval = array("d")
        self.ready = array("d")
        self.probe_at = array("d")

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def plain_loops(self) -> bool:
        """Few enough followers that plain loops over the columns beat numpy."""
        return len(self.ids) <= PLAIN_LOOPS_MAX

    def arrays(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
                              FloatArray]:
        """numpy views of w, p, tau, due, interval and ready (no copy: drop them before
        the next add or remove)."""
        return (np.frombuffer(self.w), np.frombuffer(self.p), np.frombuffer(self.tau),
                np.frombuffer(self.due), np.frombuffer(self.interval),
                np.frombuffer(self.ready))

    def index(self, follower: str) -> int:
        """Where ``follower`` is in the columns."""
        return self._index[follower]

    def add(self, peer: Peer) -> None:
        """A follower's row, kept in step with ``peer`` from now on."""
        follower = peer.follower
        self._index[follower] = len(self.ids)
        self.ids.append(follower)
        self.peers[follower] = peer
        for column, placeholder in ((self.w, 0.0), (self.p, 1.0), (self.tau, 0.0),
                                    (self.due, -math.inf), (self.interval, 0.0),
                                    (self.ready, 0.0), (self.probe_at, 0.0)):
            column.append(placeholder)
        peer.on_change = self._sync
        self._sync(peer)
        self.disturbed = True

    def remove(self, follower: str) -> None:
        i = self._index[follower]
        peer = self.peers[follower]
        peer.on_change = unwatched
        self.silent -= peer.silent
        self.unfresh -= self.due[i] != -math.inf
        self.known_intervals -= self.interval[i] > 0.0
        del self.ids[i], self.peers[follower]
        self._index = {fid: j for j, fid in enumerate(self.ids)}
        for column in (self.w, self.p, self.tau, self.due, self.interval, self.ready,
                       self.probe_at):
            del column[i]
        self.disturbed = True

    def watch(self, follower: str) -> None:
        """From now on, ``disturbed`` tells whether any row but ``follower``'s changed
        (a pick made ahead holds only while none did: ``scheduling.still_holds``)."""
        self._watched = self._index[follower]
        self.disturbed = False

    def _sync(self, peer: Peer) -> None:
        """Copy one follower's current estimates into the policy columns (each peer
        calls it when it changed)."""
        i = self._index[peer.follower]
        if i != self._watched:
            self.disturbed = True
        p = peer.reliability.value
        self.silent += (p <= 0.0) - (self.p[i] <= 0.0)
        weight = max(peer.weight.value, self.weight_floor)
        self.w[i] = (weight * peer.timing.price(peer.reliability.forgiving)
                     if self.price_by_time else weight)
        self.p[i] = p
        pace = peer.pace
        paced = self.pace_sources and pace.paced
        phased = self.pace_sources and not paced and pace.phased
        # not paced: aged from its last "nothing new" answer too (polling it sooner
        # cannot lower its age); paced: its pace says when a poll can
        tau = self.tau[i] = peer.aoi.tau if paced else max(peer.aoi.tau, peer.idle_since)
        due = math.inf if p <= 0.0 else pace.due if paced \
            else pace.ready + pace.interval if phased else -math.inf
        self.unfresh += (due != -math.inf) - (self.due[i] != -math.inf)
        self.due[i] = due
        interval = pace.interval if paced or phased else 0.0
        self.known_intervals += (interval > 0.0) - (self.interval[i] > 0.0)
        self.interval[i] = interval
        self.ready[i] = pace.ready if phased else tau
        self.probe_at[i] = peer.probe_at if p <= 0.0 else math.inf

    def wake_at(self) -> float:
        """When a poll is first worth sending: the earliest due source or probe."""
        if self.plain_loops:
            return min(min(self.due, default=math.inf), min(self.probe_at, default=math.inf))
        return float(min(np.frombuffer(self.due).min(), np.frombuffer(self.probe_at).min()))

    def first_probe(self) -> int:
        """The silent follower due for a probe first (the smallest probe_at)."""
        if self.plain_loops:
            return min(range(len(self.ids)), key=self.probe_at.__getitem__)
        return int(np.frombuffer(self.probe_at).argmin())

    def live(self) -> list[int] | IntArray:
        """The followers that answer (p > 0), by index; for many, a numpy array that
        indexes the columns as it is (a list of a thousand ints, made and read back
        on every poll while anyone is silent, would cost more than the policy)."""
        if self.plain_loops:
            return [i for i, p in enumerate(self.p) if p > 0.0]
        return np.flatnonzero(np.frombuffer(self.p) > 0.0)

