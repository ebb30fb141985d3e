"""The time an age signal spends at each value, in bounded memory.

A sawtooth segment rises from age ``s`` to ``e`` at slope 1, so the time it spends at
ages <= x is ``ramp(x - s) - ramp(x - e)``. Summing over segments needs only the count
and the sum of the starts and of the ends below x. Kept per log-spaced bin (sparse:
only bins an age fell in), that makes the cumulative time exact at every bin edge and
linear between bins, so a percentile is exact to within one bin (0.5 % of the age),
whatever the run's length, in memory that grows with the spread of ages, not with time.
"""

from __future__ import annotations

import math
from array import array

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

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

    Each bin an age fell in is a row of four columns (count and sum of the starts, count
    and sum of the ends), kept as arrays of doubles: adding a segment is two row updates,
    and a percentile reads the columns through numpy without building them anew (the
    leader computes several per follower for every stats message, on its poll thread).
    Rows are in the order their bins appeared; the sorted order is cached until a new bin
    comes.
    """

    def __init__(self) -> None:
        self._row_of_bin: dict[int, int] = {}
        self._bins = array("d")  # the bin of each row (as a float: its edges are powers)
        self._columns = (array("d"), array("d"), array("d"), array("d"))
        self._order: IntArray | None = None  # rows by increasing bin; None: to sort again

    def _row(self, b: int) -> int:
        row = self._row_of_bin.get(b)
        if row is None:
            row = self._row_of_bin[b] = len(self._bins)
            self._bins.append(b)
            for column in self._columns:
                column.append(0.0)
            self._order = None
        return row

    def add(self, start_age: float, length: float) -> None:
        if length > 0:
            end = start_age + length
            starts, start_sums, ends, end_sums = self._columns
            row = self._row(bin_of(start_age))
            starts[row] += 1.0
            start_sums[row] += start_age
            row = self._row(bin_of(end))
            ends[row] += 1.0
            end_sums[row] += end

    def percentile(self, q: float, open_start: float, open_length: float) -> float:
        """The q-quantile of age over time, including a still-open segment."""
        if not self._bins and open_length <= 0:
            return open_start
        open_rows: tuple[tuple[int, int, float], ...] = ()
        if open_length > 0:  # rows for its bins first: the columns cannot grow once viewed
            open_end = open_start + open_length
            open_rows = ((self._row(bin_of(open_start)), 0, open_start),
                         (self._row(bin_of(open_end)), 2, open_end))
        if self._order is None:
            self._order = np.argsort(np.frombuffer(self._bins), kind="stable")
        order = self._order
        acc = np.column_stack([np.frombuffer(column) for column in self._columns])
        for row, count, value in open_rows:
            acc[row, count] += 1.0
            acc[row, count + 1] += value
        acc = acc[order]
        cum = np.cumsum(acc, axis=0)
        prev = np.vstack([np.zeros(4), cum[:-1]])
        k_arr = np.frombuffer(self._bins)[order]
        upper = SMALLEST_AGE * BIN_RATIO**k_arr
        lower = np.where(k_arr == 0, 0.0, upper / BIN_RATIO)

        def below(x: FloatArray, c: FloatArray) -> FloatArray:
            result: FloatArray = (x * c[:, 0] - c[:, 1]) - (x * c[:, 2] - c[:, 3])
            return result

        xs = np.column_stack([lower, upper]).ravel()
        fs = np.column_stack([below(lower, prev), below(upper, cum)]).ravel()
        total = float(cum[-1, 3] - cum[-1, 1])
        target = q * total
        j = int(np.searchsorted(fs, target, side="left"))
        if j == 0:
            return float(xs[0])
        if j >= len(xs):
            return float(xs[-1])
        x0, x1, f0, f1 = xs[j - 1], xs[j], fs[j - 1], fs[j]
        return float(x1) if f1 <= f0 else float(x0 + (target - f0) * (x1 - x0) / (f1 - f0))
