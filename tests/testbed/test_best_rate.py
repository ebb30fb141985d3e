"""The best-rate search: few runs, each rate at most once, and a rate given alone is
still run (``--rates 1``: the best rate known, measured at the study's length)."""

from __future__ import annotations

from wiswarm_zenoh.experiments import best_of_grid


def search(grid: list[float], share: float, best: float) -> tuple[float, list[float]]:
    return search_curve(share, {rate: abs(rate - best) for rate in grid})


def search_curve(share: float, curve: dict[float, float]) -> tuple[float, list[float]]:
    measured: list[float] = []

    def cost(rate: float) -> float:
        measured.append(rate)
        return curve[rate]

    return best_of_grid(list(curve), share, cost), measured


def test_the_search_walks_to_the_best_rate_measuring_each_once() -> None:
    grid = [1.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0]
    assert search(grid, 5.0, 10.0) == (10.0, [5.0, 7.0, 10.0, 15.0])
    assert search(grid, 5.0, 1.0) == (1.0, [5.0, 7.0, 3.0, 1.0])


def test_a_rate_given_alone_is_measured() -> None:
    assert search([1.0], 4.0, 1.0) == (1.0, [1.0])
