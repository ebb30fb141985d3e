"""Clock offset of a follower from the four time-stamps of every poll (as NTP does)."""

from __future__ import annotations

from collections import deque


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
    """

    def __init__(self, samples: int = 8) -> None:
        if samples < 1:
            raise ValueError(f"samples must be >= 1, got {samples}")
        self._recent: deque[tuple[float, float]] = deque(maxlen=samples)
        self.offset = 0.0  # kept current by add and reset: read for every delivery

    def add(self, t1: float, t2: float, t3: float, t4: float) -> None:
        delay = (t4 - t1) - (t3 - t2)
        if delay < 0 or t3 < t2 or t4 < t1:
            return  # inconsistent stamps (a clock stepped): no information
        self._recent.append((delay, ((t2 - t1) + (t3 - t4)) / 2.0))
        delay, offset = min(self._recent)
        self.offset = 0.0 if abs(offset) <= delay / 2.0 else offset

    def reset(self) -> None:
        self._recent.clear()
        self.offset = 0.0

    @property
    def delay(self) -> float | None:
        return min(self._recent)[0] if self._recent else None

    def to_leader(self, follower_time: float) -> float:
        return follower_time - self.offset
