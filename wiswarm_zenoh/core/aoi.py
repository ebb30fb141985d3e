"""Age of Information of one source, with exact time statistics of its sawtooth."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


class AoITracker:
    """``A(t) = t - tau(t)``, tau being the largest time-stamp delivered so far.

    Before the first delivery the age counts from ``start`` (when tracking began); an
    update generated earlier is still delivered, it just cannot make the age negative
    or lower it below zero. Freshness is judged on the time-stamps themselves
    (``newest``), so a stamp ahead of ``now`` cannot let an older one pass. The
    sawtooth is kept as segments (age at segment start, duration), so the time average,
    percentiles and peak are exact areas and lengths, not samples.
    """

    def __init__(self, start: float) -> None:
        self.start = start
        self.tau = start
        self.newest = float("-inf")
        self.deliveries = 0
        self._last_event = start
        self._seg_age: list[float] = []
        self._seg_len: list[float] = []
        self._area = 0.0
        self._peak = 0.0

    def age(self, now: float) -> float:
        return max(0.0, now - self.tau)

    def deliver(self, timestamp: float, now: float) -> bool:
        """Record an update generated at ``timestamp``; only a newer one lowers the age."""
        if timestamp <= self.newest:
            return False
        self.newest = timestamp
        self._close_segment(now)
        self.tau = max(self.tau, min(timestamp, now))
        self.deliveries += 1
        return True

    def _close_segment(self, now: float) -> None:
        length = max(0.0, now - self._last_event)
        a0 = self._last_event - self.tau
        self._seg_age.append(a0)
        self._seg_len.append(length)
        self._area += length * (a0 + length / 2.0)
        self._peak = max(self._peak, a0 + length)
        self._last_event = max(now, self._last_event)

    def _segments(self, now: float) -> tuple[FloatArray, FloatArray]:
        ages = np.array([*self._seg_age, self._last_event - self.tau], dtype=np.float64)
        lens = np.array([*self._seg_len, max(0.0, now - self._last_event)], dtype=np.float64)
        return ages, lens

    def mean(self, now: float) -> float:
        """Time-average age over [start, now]."""
        span = now - self.start
        if span <= 0:
            return 0.0
        a0 = self._last_event - self.tau
        open_len = max(0.0, now - self._last_event)
        return (self._area + open_len * (a0 + open_len / 2.0)) / span

    def peak(self, now: float) -> float:
        """The largest age reached so far."""
        return max(self._peak, self.age(now))

    def percentile(self, q: float, now: float) -> float:
        """The age that A(t) stays at or below for a share ``q`` of the time (q in [0, 1])."""
        if not 0.0 <= q <= 1.0:
            raise ValueError(f"q must be in [0, 1], got {q}")
        starts, lens = self._segments(now)
        keep = lens > 0
        starts, lens = starts[keep], lens[keep]
        total = float(lens.sum())
        if total <= 0:
            return self.age(now)
        ends = starts + lens
        # F(x) = time with A <= x = sum ramp(x - start) - ramp(x - end); piecewise linear.
        points = np.unique(np.concatenate([starts, ends]))
        s_sorted, e_sorted = np.sort(starts), np.sort(ends)
        s_cum = np.concatenate([[0.0], np.cumsum(s_sorted)])
        e_cum = np.concatenate([[0.0], np.cumsum(e_sorted)])
        ks = np.searchsorted(s_sorted, points, side="right")
        ke = np.searchsorted(e_sorted, points, side="right")
        f = (ks * points - s_cum[ks]) - (ke * points - e_cum[ke])
        target = q * total
        j = int(np.searchsorted(f, target, side="left"))
        if j == 0:
            return float(points[0])
        if j >= len(points):
            return float(points[-1])
        x0, x1, f0, f1 = points[j - 1], points[j], f[j - 1], f[j]
        return float(x0 + (target - f0) * (x1 - x0) / (f1 - f0)) if f1 > f0 else float(x1)
