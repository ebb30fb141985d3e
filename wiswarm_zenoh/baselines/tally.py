"""What a baseline's receiver knows of one follower, as the polling leader's figures.

AoI comes from the generation time each frame carries (the core's AoITracker: a frame
older than the freshest delivered is counted as ``stale`` and never lowers the age).
``p_hat`` is the share of the frames sent that arrived, from the sequence numbers
(received over the span they cover), as the polling leader's is the share of polls
answered. Sender and receiver are taken to share one clock (one host, or synchronised
clocks): there is no poll to estimate an offset from, so ``clock_offset_s`` is 0.
"""

from __future__ import annotations

from dataclasses import dataclass

from wiswarm_zenoh.core import AoITracker, FollowerStats

NO_FRAME_P_HAT = 1.0  # before any frame, the polling leader's prior (ReliabilityEstimator)


@dataclass
class FollowerTally:
    """Counts and AoI of one follower since it joined (or its first frame came)."""

    aoi: AoITracker
    received: int = 0  # frames in, fresh or stale
    bytes: int = 0
    earlier_runs: int = 0  # sequence numbers spanned by the sender's runs before this one
    first_seq: int | None = None
    last_seq: int = 0

    def take(self, generated_at: float, seq: int, size: int, now: float) -> bool:
        """One frame in; True if it is the freshest so far (it lowers the age)."""
        if self.first_seq is None:
            self.first_seq = self.last_seq = seq
        elif seq <= self.last_seq and generated_at > self.aoi.newest:
            # The sequence went back, yet the frame is fresher than any: a new sender run.
            self.earlier_runs += self.last_seq - self.first_seq + 1
            self.first_seq = self.last_seq = seq
        else:
            self.first_seq = min(self.first_seq, seq)
            self.last_seq = max(self.last_seq, seq)
        self.received += 1
        self.bytes += size
        return self.aoi.deliver(generated_at, now)

    @property
    def attempts(self) -> int:
        """Frames sent, as far as the sequence numbers seen tell."""
        run = 0 if self.first_seq is None else self.last_seq - self.first_seq + 1
        return self.earlier_runs + run

    def stats(self, follower: str, errors: int, now: float) -> FollowerStats:
        """The polling leader's stats fields, as this system gives them."""
        aoi, attempts = self.aoi, self.attempts
        return FollowerStats(
            follower=follower, aoi_s=aoi.age(now), mean_aoi_s=aoi.mean(now),
            p95_aoi_s=aoi.percentile(0.95, now), peak_aoi_s=aoi.peak(now),
            p_hat=min(1.0, self.received / attempts) if attempts else NO_FRAME_P_HAT,
            weight=1.0, polls=0, deliveries=aoi.deliveries, timeouts=0, errors=errors,
            stale=self.received - aoi.deliveries, clock_offset_s=0.0,
        )

    def extras(self, now: float) -> dict[str, float | int]:
        """This system's own figures: deliveries/s and throughput since the start, frames
        received and lost (published next to ``stats``)."""
        span = max(now - self.aoi.start, 1e-9)
        return {"deliveries_per_s": self.aoi.deliveries / span,
                "throughput_mbps": self.bytes * 8 / span / 1e6,
                "received": self.received, "lost": max(0, self.attempts - self.received)}
