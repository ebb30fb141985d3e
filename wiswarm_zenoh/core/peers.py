"""What the leader knows of each follower, kept in one place.

Per-follower objects hold the estimators; the numbers the policy reads (w, p, tau) are
mirrored in numpy arrays so that a decision over thousands of followers is one
vectorised pass.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from wiswarm_zenoh.core.aoi import AoITracker, FloatArray
from wiswarm_zenoh.core.clock import ClockOffsetEstimator
from wiswarm_zenoh.core.config import LeaderConfig
from wiswarm_zenoh.core.estimators import ReliabilityEstimator, WeightEMA
from wiswarm_zenoh.core.fragments import Reassembler
from wiswarm_zenoh.core.wire import Want


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

    def as_dict(self) -> dict[str, float | int | str]:
        return asdict(self)


@dataclass
class Peer:
    """Estimators, reassembly and counters of one follower."""

    aoi: AoITracker
    reliability: ReliabilityEstimator
    weight: WeightEMA
    clock: ClockOffsetEstimator
    reassembler: Reassembler
    ack: tuple[int, int] | None = None
    idle_since: float = float("-inf")  # leader clock of its last "nothing new" answer
    probe_at: float = float("-inf")  # when a silent follower may be probed next
    probe_gap: float = 0.0  # the current back-off between probes (0: not silent)
    want: Want = "next"
    polls: int = 0
    timeouts: int = 0
    errors: int = 0
    stale: int = 0

    @classmethod
    def new(cls, config: LeaderConfig, now: float) -> Peer:
        return cls(
            aoi=AoITracker(now),
            reliability=ReliabilityEstimator(config.window, config.prior_p),
            weight=WeightEMA(config.alpha, config.initial_weight),
            clock=ClockOffsetEstimator(config.clock_samples),
            reassembler=Reassembler(config.max_fragments, config.max_update_bytes),
        )

    @property
    def silent(self) -> bool:
        return self.reliability.value <= 0.0

    def record_poll(self, answered: bool, now: float, interval: float, longest: float) -> None:
        """Count a poll's outcome; a silent follower's next probe backs off exponentially."""
        self.reliability.record(answered)
        if not self.silent:
            self.probe_gap, self.probe_at = 0.0, float("-inf")
            return
        self.probe_gap = interval if self.probe_gap == 0.0 else min(2 * self.probe_gap, longest)
        self.probe_at = now + self.probe_gap

    @property
    def policy_tau(self) -> float:
        """What the scheduler ages this follower from: its freshest delivery, or the last
        time it had nothing newer to send (polling it sooner cannot lower its age)."""
        return max(self.aoi.tau, self.idle_since)

    def restart(self) -> None:
        """The follower came back (new process): forget its transfer state and clock."""
        self.reassembler.reset()
        self.clock.reset()
        self.ack = None
        self.want = "fresh"

    def stats(self, follower: str, now: float) -> FollowerStats:
        return FollowerStats(
            follower=follower, aoi_s=self.aoi.age(now), mean_aoi_s=self.aoi.mean(now),
            p95_aoi_s=self.aoi.percentile(0.95, now), peak_aoi_s=self.aoi.peak(now),
            p_hat=self.reliability.value, weight=self.weight.value, polls=self.polls,
            deliveries=self.aoi.deliveries, timeouts=self.timeouts, errors=self.errors,
            stale=self.stale, clock_offset_s=self.clock.offset,
        )


class PeerTable:
    """Followers in join order, with the arrays (w, p, tau, probe_at) the leader reads.

    ``tau`` is each follower's ``policy_tau``: the scheduler's view of its freshness;
    ``probe_at`` is when a silent follower is due for a probe (+inf if not silent).
    """

    def __init__(self) -> None:
        self.ids: list[str] = []
        self.peers: dict[str, Peer] = {}
        self._index: dict[str, int] = {}
        self.w: FloatArray = np.zeros(0)
        self.p: FloatArray = np.zeros(0)
        self.tau: FloatArray = np.zeros(0)
        self.probe_at: FloatArray = np.zeros(0)

    def __len__(self) -> int:
        return len(self.ids)

    def add(self, follower: str, peer: Peer) -> None:
        self._index[follower] = len(self.ids)
        self.ids.append(follower)
        self.peers[follower] = peer
        self.w = np.append(self.w, peer.weight.value)
        self.p = np.append(self.p, peer.reliability.value)
        self.tau = np.append(self.tau, peer.policy_tau)
        self.probe_at = np.append(self.probe_at, _probe_at(peer))

    def remove(self, follower: str) -> None:
        i = self._index[follower]
        del self.ids[i], self.peers[follower]
        self._index = {fid: j for j, fid in enumerate(self.ids)}
        self.w, self.p, self.tau, self.probe_at = (
            np.delete(a, i) for a in (self.w, self.p, self.tau, self.probe_at)
        )

    def sync(self, follower: str) -> None:
        """Copy one follower's current estimates into the policy arrays."""
        i = self._index[follower]
        peer = self.peers[follower]
        self.w[i], self.p[i], self.tau[i], self.probe_at[i] = (
            peer.weight.value, peer.reliability.value, peer.policy_tau, _probe_at(peer)
        )


def _probe_at(peer: Peer) -> float:
    return peer.probe_at if peer.silent else float("inf")
