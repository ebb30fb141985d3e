"""The fine search for a fixed rate: on curves shaped like a push system's AoI against
its rate (flat while the channel keeps up, a cliff once it does not), it finds the best
rate within its 5 % step, from either side, with noise, in a handful of runs."""

from __future__ import annotations

import math
import random
from collections.abc import Callable

import pytest

from wiswarm_zenoh.experiments.rate_search import STEP, RateCosts, fine_search


def cliff(best: float) -> Callable[[float], float]:
    """Mean AoI of N robots pushing at ``rate``: about one frame interval plus the
    floor below ``best`` (the channel's share), queues building past it."""
    def cost(rate: float) -> float:
        if rate <= best:
            return 0.5 / rate + 0.06
        return 0.5 / best + 0.06 + 20.0 * (rate - best)
    return cost


@pytest.mark.parametrize(("start", "runs"), [(1.0, 12), (2.1, 9), (3.0, 9), (9.0, 16)])
def test_the_best_rate_just_below_the_cliff_is_found_within_the_step(start: float,
                                                                      runs: int) -> None:
    costs = RateCosts(cliff(2.1))  # N = 14 on the WiFi medium: the share is 2.1 fps
    best = fine_search(costs, start)
    assert 2.1 / (1 + 2 * STEP) <= best <= 2.1, costs.tried
    assert len(costs.tried) <= runs, costs.tried  # more, the farther the start
    # the stopping rule: a rate tried within 5 % on each side of the best
    rates = sorted(r for r, _ in costs.tried)
    i = rates.index(best)
    assert rates[i + 1] / best <= 1 + STEP and best / rates[i - 1] <= 1 + STEP


def test_noise_of_a_few_percent_still_lands_near_the_best() -> None:
    for seed in range(20):
        rng = random.Random(seed)
        curve = cliff(10.0)

        def noisy(rate: float, curve: Callable[[float], float] = curve,
                  rng: random.Random = rng) -> float:
            return curve(rate) * (1 + 0.03 * rng.gauss(0, 1))

        best = fine_search(noisy, 6.0)
        assert cliff(10.0)(best) <= 1.15 * cliff(10.0)(10.0), (seed, best)


def test_overloaded_rates_differ_by_noise_alone_and_the_search_leaves_them() -> None:
    """Started above the cliff (the share overestimated), where every rate's age is
    seconds of noise: the walk goes down first, to the rates that fit."""
    for seed in range(20):
        rng = random.Random(seed)

        def overloaded(rate: float, rng: random.Random = rng) -> float:
            return 0.5 / rate + 0.06 if rate <= 4.7 else rng.uniform(1.0, 6.0)

        costs = RateCosts(overloaded)
        best = fine_search(costs, 5.07)  # the sim's WiFi at N = 14: cliff at 4.7 fps
        assert 4.7 / (1 + 2 * STEP) <= best <= 4.7, (seed, costs.tried)
        assert overloaded(best) <= 1.05 * overloaded(4.7)


def test_a_run_that_delivered_nothing_is_worse_than_any() -> None:
    def cost(rate: float) -> float:
        return math.nan if rate > 5.0 else 1.0 / rate

    assert 5.0 / (1 + 2 * STEP) <= fine_search(cost, 4.0) <= 5.0


def test_the_highest_allowed_rate_is_not_passed() -> None:
    costs = RateCosts(lambda rate: 1.0 / rate)  # ever better: the camera's own rate wins
    assert fine_search(costs, 20.0, high=30.0) == 30.0
    assert max(r for r, _ in costs.tried) == 30.0
    assert fine_search(lambda rate: rate, 30.0, high=30.0) < 2.0  # ever worse: down


def test_a_start_that_is_not_a_rate_is_refused() -> None:
    with pytest.raises(ValueError, match="start and high must be rates > 0"):
        fine_search(lambda rate: rate, 0.0)
