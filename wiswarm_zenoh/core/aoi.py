"""Age of Information of one source, with exact time statistics of its sawtooth."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from wiswarm_zenoh.core.age_histogram import AgeHistogram

FloatArray = npt.NDArray[np.float64]


class AoITracker:
    """``A(t) = t - tau(t)``, tau being the largest time-stamp delivered so far.

    Before the first delivery the age counts from ``start`` (when tracking began), or is
    ``initial_age`` there (a measurement window opened mid-run, the freshest update so
    far that old); an
    update generated earlier is still delivered, it just cannot make the age negative
    or lower it below zero. Freshness is judged on the time-stamps themselves
    (``newest``), taken no later than their delivery, so a stamp ahead of ``now``
    neither lets an older one pass nor holds back the genuine ones that follow. The
    time average and the peak are exact (areas and maxima of the sawtooth); percentiles
    come from an ``AgeHistogram`` of the sawtooth, within 0.5 %, in bounded memory.
    """

    def __init__(self, start: float, initial_age: float = 0.0) -> None:
        if not initial_age >= 0.0:
            raise ValueError(f"initial_age must be >= 0, got {initial_age!r}")
        self.start = start
        self.tau = start - initial_age
        # With an initial age, an update that old was delivered: no older one is fresh.
        self.newest = self.tau if initial_age > 0 else float("-inf")
        self.deliveries = 0
        self._last_event = start
        self._histogram = AgeHistogram()
        self._area = 0.0
        self._peak = 0.0

    def age(self, now: float) -> float:
        """Seconds since the freshest update delivered was generated (never negative)."""
        return max(0.0, now - self.tau)

    def deliver(self, timestamp: float, now: float) -> bool:
        """Record an update generated at ``timestamp``; only a newer one lowers the age."""
        if timestamp <= self.newest:
            return False
        # Never newer than ``now``: a stamp ahead of the clock must not make genuine
        # updates generated before it look old afterwards.
        self.newest = min(timestamp, now)
        # close the sawtooth segment that ends now
        last = self._last_event
        length = max(0.0, now - last)
        a0 = last - self.tau
        self._histogram.add(a0, length)
        self._area += length * (a0 + length / 2.0)
        self._peak = max(self._peak, a0 + length)
        self._last_event = max(now, last)
        self.tau = max(self.tau, min(timestamp, now))
        self.deliveries += 1
        return True

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
        """The age that A(t) stays at or below for a share ``q`` of the time (q in [0, 1]),
        exact to within 0.5 % (see ``AgeHistogram``)."""
        if not 0.0 <= q <= 1.0:
            raise ValueError(f"q must be in [0, 1], got {q}")
        open_length = max(0.0, now - self._last_event)
        return self._histogram.percentile(q, self._last_event - self.tau, open_length)
