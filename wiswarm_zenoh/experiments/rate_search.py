"""The best fixed rate, searched finely: a golden-section search on the logarithm of
the rate, with no I/O (each ``cost(rate)`` is a measured run, the caller's).

A push system's mean AoI against its rate is flat-ish while the channel keeps up
(fresher frames as the rate rises) and climbs steeply once the offered load passes the
channel's share of each robot (queues build): its best is just below a cliff. A grid of
whole frames per second misses it (1 fps best at N = 14 because 3 fps already fills the
air, though 2.1 fps is the share). The search starts at the channel's share and tries
the rate ``GROWTH`` below it first: above the share every rate overloads the channel,
and their ages, all seconds, differ by noise alone, so a walk up from an overloaded
start could settle on noise. It walks towards the better side until a rate is worse (a
bracket a < b < c with b the best yet), then narrows the bracket golden-section fashion
until b's neighbours on both sides are within ``step`` (5 %) of it. Each rate is
measured once; a run that delivered nothing (NaN, inf) counts as worse than any.
"""

from __future__ import annotations

import math
from collections.abc import Callable

STEP = 0.05  # the search ends once the best rate's tried neighbours are this close
GROWTH = 1.25  # the bracketing walk's factor
SHRINK = (3 - math.sqrt(5)) / 2  # golden section: 0.382 of the larger interval
BUDGET = 16  # runs at most (7 to 9 from the share of a cliff-shaped curve)
LOWEST_SHARE = 1 / 64  # the walk down stops at this share of the start (or high)


class RateCosts:
    """``cost`` memoised by rate, every rate tried kept in order (for the report)."""

    def __init__(self, cost: Callable[[float], float]) -> None:
        self._cost = cost
        self.tried: list[tuple[float, float]] = []
        self._known: dict[float, float] = {}

    def __call__(self, rate: float) -> float:
        if rate not in self._known:
            value = self._cost(rate)
            self.tried.append((rate, value))
            self._known[rate] = value if math.isfinite(value) else math.inf
        return self._known[rate]


def fine_search(cost: Callable[[float], float], start: float, *, high: float = math.inf,
                step: float = STEP, budget: int = BUDGET) -> float:
    """The rate in (0, ``high``] with the lowest ``cost`` (see the module), from
    ``start`` (the channel's share, say): ValueError for a start that is not > 0."""
    if not (math.isfinite(start) and start > 0 and high > 0):
        raise ValueError(f"start and high must be rates > 0, got {start!r} and {high!r}")
    f = cost if isinstance(cost, RateCosts) else RateCosts(cost)
    b = min(start, high)
    low = b * LOWEST_SHARE
    a = max(b / GROWTH, low)
    if f(a) < f(b):  # better below: walk down until a rate is worse (or the lowest)
        c, b = b, a
        while (a := max(b / GROWTH, low)) < b and f(a) < f(b):
            c, b = b, a
            if len(f.tried) >= budget:
                return b
    else:  # walk up until a rate is worse (or the highest allowed)
        while (c := min(b * GROWTH, high)) > b and f(c) < f(b):
            a, b = b, c
            if len(f.tried) >= budget:
                return b
    # a <= b <= c, b the best tried; a bound reached is a side of no width
    while max(c / b, b / a) > 1 + step and len(f.tried) < budget:
        upper = math.log(c / b) >= math.log(b / a)
        x = b * (c / b) ** SHRINK if upper else b / (b / a) ** SHRINK
        if f(x) < f(b):
            a, b, c = (b, x, c) if upper else (a, x, b)
        elif upper:
            c = x
        else:
            a = x
    return b
