"""The best-rate search: few runs, each rate at most once, and a rate given alone is
still run (``--rates 1``: the best rate known, measured at the study's length)."""

from __future__ import annotations

from wiswarm_zenoh.experiments import best_of_grid


def search(grid: list[float], share: float, best: float) -> tuple[float, list[float]]:
    return search_curve(share, {rate: abs(rate - best) for rate in grid})


def search_curve(share: float, curve: dict[float, float], up_first: bool = True
                 ) -> tuple[float, list[float]]:
    measured: list[float] = []

    def cost(rate: float) -> float:
        measured.append(rate)
        return curve[rate]

    return best_of_grid(list(curve), share, cost, up_first), measured


def test_the_search_walks_to_the_best_rate_measuring_each_once() -> None:
    grid = [1.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0]
    assert search(grid, 5.0, 10.0) == (10.0, [5.0, 7.0, 10.0, 15.0])
    assert search(grid, 5.0, 1.0) == (1.0, [5.0, 7.0, 3.0, 1.0])


def test_a_rate_given_alone_is_measured() -> None:
    assert search([1.0], 4.0, 1.0) == (1.0, [1.0])


def test_tried_below_first_the_search_leaves_an_overloaded_start() -> None:
    """Both rates above the share overload the channel and their ages are noise (the
    WiFi medium at N = 8, measured): tried upwards first the search stays there, tried
    downwards first it finds the rate that fits."""
    curve = {2.0: 260.0, 3.0: 200.0, 5.0: 1558.0, 6.0: 1369.0, 7.5: 2227.0, 10.0: 3000.0}
    assert search_curve(5.05, curve) == (6.0, [5.0, 6.0, 7.5])
    assert search_curve(5.05, curve, up_first=False) == (3.0, [5.0, 3.0, 2.0])
