"""What the leader knows of each follower, kept in one place.

Per-follower objects hold the estimators; the numbers the policy reads (w, p, tau) are
mirrored in columns of doubles that a plain loop reads as floats (a few followers) and
numpy views without a copy (thousands: one vectorised pass).
"""

from __future__ import annotations

import math
from array import array
from collections import deque
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from wiswarm_zenoh.core.aoi import AoITracker, FloatArray
from wiswarm_zenoh.core.clock import ClockOffsetEstimator
from wiswarm_zenoh.core.config import LeaderConfig
from wiswarm_zenoh.core.estimators import ReliabilityEstimator, WeightEMA
from wiswarm_zenoh.core.fragments import Reassembler
from wiswarm_zenoh.core.poll_timing import PollTiming, SwarmPollTimes
from wiswarm_zenoh.core.sources import SourcePace
from wiswarm_zenoh.core.wire import Want

IntArray = npt.NDArray[np.intp]
LATE_KEPT = 8  # unanswered polls whose late replies still count (see Peer.timed_out)


@dataclass(frozen=True)
class FollowerStats:
    """One follower as the leader sees it (the JSON of DESIGN.md section 3, and more)."""

    follower: str
    aoi_s: float
    mean_aoi_s: float
    p95_aoi_s: float
    peak_aoi_s: float
    p_hat: float
    weight: float
    polls: int
    deliveries: int
    timeouts: int
    errors: int
    stale: int
    clock_offset_s: float
    present: bool = True  # False: it left (token gone); its age keeps growing here

    def as_dict(self) -> dict[str, float | int | str]:
        """The record as a plain dict, the stats JSON's fields."""
        # Its fields are plain numbers and a string: a shallow copy is the whole of it,
        # 30 times cheaper than ``asdict``'s deep copy (made for each follower in each stats put).
        return dict(vars(self))


@dataclass
class Peer:
    """Estimators, reassembly and counters of one follower."""

    aoi: AoITracker
    reliability: ReliabilityEstimator
    weight: WeightEMA
    clock: ClockOffsetEstimator
    reassembler: Reassembler
    timing: PollTiming
    pace: SourcePace = field(default_factory=SourcePace)
    ack: tuple[int, int] | None = None
    idle_since: float = float("-inf")  # leader clock of its last "nothing new" answer
    unsettled_tau: float = float("-inf")  # an update taken, its checksum not verified yet
    probe_at: float = float("-inf")  # when a silent follower may be probed next
    probe_gap: float = 0.0  # the current back-off between probes (0: not silent)
    # (seq, sent at) of its latest polls that went unanswered: a reply to one of them,
    # late, still tells the link's pace (replies queue behind each other on a slow link)
    timed_out: deque[tuple[int, float]] = field(
        default_factory=lambda: deque(maxlen=LATE_KEPT))
    silent_since: float = 0.0  # when it last went silent
    left_at: float | None = None  # when its token went (None: present, or not told)
    want: Want = "next"
    polls: int = 0
    timeouts: int = 0
    errors: int = 0
    stale: int = 0

    @classmethod
    def new(cls, config: LeaderConfig, now: float, swarm: SwarmPollTimes) -> Peer:
        """A follower just joined, judged by ``swarm``'s poll times until it answers."""
        return cls(
            aoi=AoITracker(now),
            reliability=ReliabilityEstimator(config.window, config.prior_p),
            weight=WeightEMA(config.alpha, config.initial_weight),
            clock=ClockOffsetEstimator(config.clock_samples),
            reassembler=Reassembler(config.max_fragments, config.max_update_bytes),
            timing=PollTiming(config.timeout, config.timeout_floor if config.adaptive_timeout
                              else config.timeout, swarm),
        )

    @property
    def silent(self) -> bool:
        return self.reliability.value <= 0.0

    def record_poll(self, answered: bool, now: float, interval: float, longest: float) -> None:
        """Count a poll's outcome; a silent follower's next probe backs off exponentially."""
        if not answered:
            self.timing.timed_out(silent=self.silent)
        self.reliability.record(answered)
        if self.reliability.value > 0.0:
            self.probe_gap, self.probe_at = 0.0, -math.inf
            return
        self.probe_gap = interval if self.probe_gap == 0.0 else min(2 * self.probe_gap, longest)
        self.probe_at = now + self.probe_gap

    @property
    def policy_tau(self) -> float:
        """What the scheduler ages this follower from: its freshest delivery, counting
        one taken but not yet settled (when a poll can lower that age: ``pace``)."""
        return max(self.aoi.tau, self.unsettled_tau)

    def late(self, poll_seq: int) -> float | None:
        """When its poll ``poll_seq`` was sent, if that poll went unanswered lately (and
        is then forgotten: one late reply teaches once)."""
        for entry in self.timed_out:
            if entry[0] == poll_seq:
                self.timed_out.remove(entry)
                return entry[1]
        return None

    def restart(self) -> None:
        """The follower came back (new process): forget its transfer state and clock."""
        self.reassembler.reset()
        self.clock.reset()
        self.timing.reset()
        self.pace.reset()
        self.timed_out.clear()
        self.ack = None
        self.want = "fresh"

    def stats(self, follower: str, now: float, present: bool = True) -> FollowerStats:
        """Its figures at ``now``: its age grows after it left, its mean, p95 and peak
        are those of its time present."""
        until = now if present or self.left_at is None else min(now, self.left_at)
        return FollowerStats(
            follower=follower, aoi_s=self.aoi.age(now), mean_aoi_s=self.aoi.mean(until),
            p95_aoi_s=self.aoi.percentile(0.95, until), peak_aoi_s=self.aoi.peak(until),
            p_hat=self.reliability.value, weight=self.weight.value, polls=self.polls,
            deliveries=self.aoi.deliveries, timeouts=self.timeouts, errors=self.errors,
            stale=self.stale, clock_offset_s=self.clock.offset, present=present,
        )


PLAIN_LOOPS_MAX = 64  # followers up to which plain loops beat numpy (its cost per call
# is fixed)


class PeerTable:
    """Followers in join order, with the columns (w, p, tau, due, interval, probe_at) the
    leader reads.

    ``w`` is each follower's weight raised to ``weight_floor`` (with ``price_by_time``,
    per unit of its polls' expected time: ``PollTiming.price``); ``tau`` its
    ``policy_tau``: the scheduler's view of its freshness; ``due`` and ``interval`` its
    source's pace (``sources``: -inf and 0 for a source taken as always fresh, +inf for a
    silent follower, whose probes ``probe_at`` times: when it is due for one, +inf if
    not silent); ``silent`` counts those with p = 0, so that the common case (none)
    costs the scheduler no pass over the columns.
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
        self.unfresh = 0  # followers whose due is not -inf (paced or silent)
        self._index: dict[str, int] = {}
        self.w = array("d")
        self.p = array("d")
        self.tau = array("d")
        self.due = array("d")
        self.interval = array("d")
        self.probe_at = array("d")

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def plain_loops(self) -> bool:
        """Few enough followers that plain loops over the columns beat numpy."""
        return len(self.ids) <= PLAIN_LOOPS_MAX

    def arrays(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """numpy views of w, p, tau, due and interval (no copy: drop them before the next
        add or remove)."""
        return (np.frombuffer(self.w), np.frombuffer(self.p), np.frombuffer(self.tau),
                np.frombuffer(self.due), np.frombuffer(self.interval))

    def index(self, follower: str) -> int:
        """Where ``follower`` is in the columns."""
        return self._index[follower]

    def add(self, follower: str, peer: Peer) -> None:
        self._index[follower] = len(self.ids)
        self.ids.append(follower)
        self.peers[follower] = peer
        for column, placeholder in ((self.w, 0.0), (self.p, 1.0), (self.tau, 0.0),
                                    (self.due, -math.inf), (self.interval, 0.0),
                                    (self.probe_at, 0.0)):
            column.append(placeholder)
        self.sync(follower)

    def remove(self, follower: str) -> None:
        i = self._index[follower]
        self.silent -= self.peers[follower].silent
        self.unfresh -= self.due[i] != -math.inf
        del self.ids[i], self.peers[follower]
        self._index = {fid: j for j, fid in enumerate(self.ids)}
        del self.w[i], self.p[i], self.tau[i], self.due[i], self.interval[i], self.probe_at[i]

    def sync(self, follower: str) -> None:
        """Copy one follower's current estimates into the policy columns."""
        i = self._index[follower]
        peer = self.peers[follower]
        p = peer.reliability.value
        self.silent += (p <= 0.0) - (self.p[i] <= 0.0)
        weight = max(peer.weight.value, self.weight_floor)
        self.w[i] = (weight * peer.timing.price(peer.reliability.forgiving)
                     if self.price_by_time else weight)
        self.p[i] = p
        pace = peer.pace
        paced = self.pace_sources and pace.paced
        # not paced: aged from its last "nothing new" answer too (polling it sooner
        # cannot lower its age); paced: its pace says when a poll can
        self.tau[i] = peer.policy_tau if paced else max(peer.policy_tau, peer.idle_since)
        due = math.inf if p <= 0.0 else pace.due if paced else -math.inf
        self.unfresh += (due != -math.inf) - (self.due[i] != -math.inf)
        self.due[i] = due
        self.interval[i] = pace.interval if paced else 0.0
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

