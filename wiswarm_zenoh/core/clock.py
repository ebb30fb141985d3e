"""Clock offset of a follower from the four time-stamps of every poll (as NTP does)."""

from __future__ import annotations

from collections import deque

STAMP_SLACK = 0.005  # seconds: clock reads, rounding and drift between two polls


class ClockOffsetEstimator:
    """Estimates ``follower_clock - leader_clock``.

    Each poll gives t1 (leader send), t2 (follower receive), t3 (follower send) and
    t4 (leader receive): offset = ((t2 - t1) + (t3 - t4)) / 2 with error at most half the
    round-trip delay (t4 - t1) - (t3 - t2). Of the last ``samples`` samples the one with
    the smallest delay is used: queueing inflates delay and skews offset together.

    An estimate within half the delay of zero cannot be told apart from zero, and is
    most often an artefact of asymmetric paths (a tiny poll, a large reply): then the
    clocks are taken as synchronised (as NTP-disciplined ones are), which removes that
    bias while a clock that is really off (by more than the bound) is still corrected.

    A sample is also a claim by whoever answered: ``judge`` refuses one that no clock of
    this follower could give (stamps out of order, or an offset further from the estimate
    than both samples' delays allow), so one forged reply cannot move the offset. Only
    ``samples`` refused polls in a row (the follower's clock really stepped, or the first
    sample was the forgery) re-anchor the estimate on the new sample.
    """

    def __init__(self, samples: int = 8) -> None:
        if samples < 1:
            raise ValueError(f"samples must be >= 1, got {samples}")
        self.samples = samples
        self._recent: deque[tuple[float, float]] = deque(maxlen=samples)
        self.offset = 0.0  # kept current by add and reset: read for every delivery
        self.refused_in_a_row = 0

    def judge(self, t1: float, t2: float, t3: float, t4: float,
              reanchor: bool = True) -> str | None:
        """Why these stamps cannot come from this follower's clock, or None if they can.
        ``reanchor`` False: this poll was refused once already (a streak of refused
        polls, not of replies to one poll, re-anchors the estimate)."""
        delay = (t4 - t1) - (t3 - t2)
        if t3 < t2 - STAMP_SLACK or delay < -STAMP_SLACK:
            return (f"clock stamps out of order (received {t2:.6f}, sent {t3:.6f}, "
                    f"round trip {t4 - t1:.6f} s)")
        if reanchor and self.refused_in_a_row + 1 >= self.samples:
            return None
        off, bound = self._off(t1, t2, t3, t4)
        if off is not None:
            return f"clock stamps {off:+.3f} s off this follower's clock (at most {bound:.3f} s)"
        return None

    def _off(self, t1: float, t2: float, t3: float, t4: float) -> tuple[float | None, float]:
        """How far this sample's offset is from the estimate, if further than genuine
        samples can be (None otherwise, and while nothing is known), and that bound."""
        if not self._recent:
            return None, 0.0
        delay = (t4 - t1) - (t3 - t2)
        offset = ((t2 - t1) + (t3 - t4)) / 2.0
        # Genuine samples lie within half their delay of the true offset; the estimate
        # (or zero, when snapped) within the smallest delay of it.
        bound = max(delay, 0.0) / 2.0 + min(self._recent)[0] + STAMP_SLACK
        off = offset - self.offset
        return (off if abs(off) > bound else None), bound

    def refused(self) -> None:
        """A poll answered only by stamps ``judge`` refused."""
        self.refused_in_a_row += 1

    def add(self, t1: float, t2: float, t3: float, t4: float) -> None:
        """Take a sample ``judge`` accepted (a refused streak long enough re-anchors)."""
        delay = (t4 - t1) - (t3 - t2)
        if delay < 0 or t3 < t2 or t4 < t1:
            return  # stamps within the slack of inconsistent: no information
        if self._off(t1, t2, t3, t4)[0] is not None:  # accepted as an outlier: re-anchor
            self._recent.clear()
        self.refused_in_a_row = 0
        self._recent.append((delay, ((t2 - t1) + (t3 - t4)) / 2.0))
        delay, offset = min(self._recent)
        self.offset = 0.0 if abs(offset) <= delay / 2.0 else offset

    def reset(self) -> None:
        self._recent.clear()
        self.offset = 0.0
        self.refused_in_a_row = 0

    @property
    def delay(self) -> float | None:
        return min(self._recent)[0] if self._recent else None

    def to_leader(self, follower_time: float) -> float:
        return follower_time - self.offset

    def from_leader(self, leader_time: float) -> float:
        return leader_time + self.offset
