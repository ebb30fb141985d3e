"""What a simulated run reports: AoI statistics per follower, throughput, the AoI bound."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Protocol

from wiswarm_zenoh.core.aoi import AoITracker


class FrameSink(Protocol):
    """Where a delivered frame goes: the leader's ground-truth AoI tracker of a follower."""

    def deliver(self, timestamp: float, now: float) -> bool: ...


def lower_bound(w: Sequence[float], p: Sequence[float]) -> float:
    """Kadota et al.'s bound on ``(1/N) sum_i w_i E[A_i]`` in slots, any policy."""
    n = len(w)
    if n == 0 or n != len(p):
        raise ValueError("w and p must be non-empty and of equal length")
    root_sum = sum(math.sqrt(wi / pi) for wi, pi in zip(w, p, strict=True))
    return root_sum**2 / (2 * n) + sum(w) / (2 * n)


@dataclass(frozen=True)
class FollowerMetrics:
    """One follower's AoI (seconds) and delivered throughput over a run."""

    follower: str
    mean_aoi_s: float
    p95_aoi_s: float
    peak_aoi_s: float
    deliveries: int
    throughput_fps: float
    throughput_mbps: float

    @classmethod
    def from_tracker(
        cls, follower: str, tracker: AoITracker, now: float, frame_bytes: int
    ) -> FollowerMetrics:
        span = now - tracker.start
        fps = tracker.deliveries / span if span > 0 else 0.0
        return cls(
            follower=follower,
            mean_aoi_s=tracker.mean(now),
            p95_aoi_s=tracker.percentile(0.95, now),
            peak_aoi_s=tracker.peak(now),
            deliveries=tracker.deliveries,
            throughput_fps=fps,
            throughput_mbps=fps * frame_bytes * 8 / 1e6,
        )


MEAN_FIELDS = ("mean_aoi_s", "p95_aoi_s", "peak_aoi_s", "throughput_fps", "throughput_mbps")


@dataclass(frozen=True)
class WifiResult:
    """A run over the ``wifi`` channel: per follower metrics and channel counters."""

    system: str
    n: int
    rate: float | None
    frame_bytes: int
    duration: float
    seed: int
    followers: list[FollowerMetrics]
    channel: dict[str, float] = field(default_factory=dict)

    def mean(self, name: str) -> float:
        """Average of one per-follower metric over the followers."""
        return sum(float(getattr(f, name)) for f in self.followers) / len(self.followers)

    def as_dict(self) -> dict[str, object]:
        means: dict[str, float] = {name: self.mean(name) for name in MEAN_FIELDS}
        means["deliveries"] = self.mean("deliveries")
        return {
            "n": self.n,
            "system": self.system,
            "rate": self.rate,
            "frame_bytes": self.frame_bytes,
            "duration": self.duration,
            "seed": self.seed,
            "mean": means,
            # Weights are all 1 over wifi, so the weighted sum of AoI is the mean AoI.
            "ewsaoi_s": means["mean_aoi_s"],
            "followers": [asdict(f) for f in self.followers],
            "channel": self.channel,
        }
