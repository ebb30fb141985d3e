"""The time an age signal spends at each value, in bounded memory.

A sawtooth segment rises from age ``s`` to ``e`` at slope 1, so the time it spends at
ages <= x is ``ramp(x - s) - ramp(x - e)``. Summing over segments, the time at ages
<= x is ``x * (starts - ends below x) - (sum of those starts - sum of those ends)``:
kept per log-spaced bin (sparse: only bins an age fell in), as one count and one sum per
bin, that makes the cumulative time exact at every bin edge and linear between bins, so
a percentile is exact to within one bin (0.5 % of the age), whatever the run's length,
in memory that grows with the spread of ages, not with time.
"""

from __future__ import annotations

import math
from array import array
from bisect import bisect_left

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

SMALLEST_AGE = 1e-5  # seconds; bin 0 holds [0, SMALLEST_AGE)
BIN_RATIO = 1.005  # consecutive bin edges differ by 0.5 %
_LOG_RATIO = math.log(BIN_RATIO)


def bin_of(age: float) -> int:
    """Bin k >= 1 holds [SMALLEST_AGE * BIN_RATIO**(k - 1), SMALLEST_AGE * BIN_RATIO**k)."""
    if age < SMALLEST_AGE:
        return 0
    return 1 + int(math.log(age / SMALLEST_AGE) / _LOG_RATIO)


class AgeHistogram:
    """Time spent at each age, from sawtooth segments (start age, length).

    Rows are the bins an age fell in, sorted by bin, in columns of doubles: segments
    starting there minus those ending there, the sum of those starts minus the sum of
    those ends, and the bin's upper edge. Adding a segment is two row updates (a new bin,
    rare once a run settles, is an insertion); a percentile is a few numpy passes over
    the columns and no copy of them, because the leader computes one per follower for
    every stats message, on its poll thread, for hundreds of followers. The segment
    still open is taken exactly where it is, and adds no row.
    """

    def __init__(self) -> None:
        self._bins = array("q")
        self._counts = array("d")
        self._sums = array("d")
        self._uppers = array("d")
        self._total = 0.0  # the length of every segment added

    def _row(self, b: int) -> int:
        row = bisect_left(self._bins, b)
        if row == len(self._bins) or self._bins[row] != b:
            self._bins.insert(row, b)
            self._counts.insert(row, 0.0)
            self._sums.insert(row, 0.0)
            self._uppers.insert(row, SMALLEST_AGE * BIN_RATIO**b)
        return row

    def add(self, start_age: float, length: float) -> None:
        if length > 0:
            end = start_age + length
            row = self._row(bin_of(start_age))
            self._counts[row] += 1.0
            self._sums[row] += start_age
            row = self._row(bin_of(end))
            self._counts[row] -= 1.0
            self._sums[row] -= end
            self._total += length

    def percentile(self, q: float, open_start: float, open_length: float) -> float:
        """The q-quantile of age over time, including a still-open segment: the first age
        at which the time spent at or below it reaches q of the whole."""
        open_length = max(open_length, 0.0)
        if not self._bins:
            return open_start + q * open_length
        target = q * (self._total + open_length)
        upper = np.frombuffer(self._uppers)
        # (ufunc methods: numpy's function wrappers would double the cost of the whole)
        cum_counts = np.add.accumulate(np.frombuffer(self._counts))
        cum_sums = np.add.accumulate(np.frombuffer(self._sums))
        at_upper = upper * cum_counts  # the time at ages up to each row's upper edge
        at_upper -= cum_sums
        if open_length > 0:
            ramp = upper - open_start
            np.minimum(np.maximum(ramp, 0.0, out=ramp), open_length, out=ramp)
            at_upper += ramp
        row = int(at_upper.searchsorted(target))
        if row == len(self._bins):  # beyond every row: only the open segment rises
            last = self._uppers[-1]
            if open_length <= 0:
                return last
            return max(last, min(open_start + target - self._total, open_start + open_length))
        lower = 0.0 if self._bins[row] == 0 else self._uppers[row] / BIN_RATIO
        at_lower = (lower * (float(cum_counts[row]) - self._counts[row])
                    - (float(cum_sums[row]) - self._sums[row])
                    + min(max(lower - open_start, 0.0), open_length))
        if at_lower < target:  # inside this row's bin
            x0, x1, f0, f1 = lower, self._uppers[row], at_lower, float(at_upper[row])
        elif row == 0:  # at the first edge, or before it on the open segment
            return min(lower, open_start + target) if open_length > 0 else lower
        else:  # in the gap between the row before and this one
            x0, x1, f0, f1 = self._uppers[row - 1], lower, float(at_upper[row - 1]), at_lower
        if open_length <= 0:
            return _solve(target, x0, x1, f0, f1)
        return _solve_with_open(target, x0, x1, f0, f1, open_start, open_length)


def _solve(target: float, x0: float, x1: float, f0: float, f1: float) -> float:
    """Where the line from (x0, f0) to (x1, f1) reaches ``target`` (x1 if it is flat)."""
    return x1 if f1 <= f0 else x0 + (target - f0) * (x1 - x0) / (f1 - f0)


def _solve_with_open(target: float, x0: float, x1: float, f0: float, f1: float,
                     start: float, length: float) -> float:
    """``_solve`` where the open segment's ramp, exact, is part of f: its kinks (its
    start and end ages) inside (x0, x1) split the line in pieces."""

    def ramp(x: float) -> float:
        return min(max(x - start, 0.0), length)

    closed0, closed1 = f0 - ramp(x0), f1 - ramp(x1)

    def f(x: float) -> float:
        return closed0 + (closed1 - closed0) * (x - x0) / (x1 - x0) + ramp(x)

    a, fa = x0, f0
    for kink in (start, start + length):
        if a < kink < x1:
            fk = f(kink)
            if fk >= target:
                return _solve(target, a, kink, fa, fk)
            a, fa = kink, fk
    return _solve(target, a, x1, fa, f1)
