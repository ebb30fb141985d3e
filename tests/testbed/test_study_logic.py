"""The study's own logic, without a channel: the best-rate searches and the window's AoI."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from wiswarm_zenoh.experiments.testbed_study import (
    Job,
    StudyConfig,
    StudyResults,
    best_rate,
    plan,
    searched,
)
from wiswarm_zenoh.sim.metrics import FollowerMetrics, WifiResult
from wiswarm_zenoh.testbed.run import RunOutcome, RunSpec, window_metrics


def _search(config: StudyConfig, n: int, aoi_of_rate: Callable[[float], float]
            ) -> tuple[float, list[float]]:
    """The search's choice, and the rates it measured, against a known AoI curve."""
    measured: list[float] = []

    def run(spec: RunSpec) -> RunOutcome:
        measured.append(spec.rate)
        metrics = FollowerMetrics("uav0", aoi_of_rate(spec.rate), 0.0, 0.0, 1, 1.0, 1.0)
        return RunOutcome(WifiResult(spec.system, n, spec.rate, spec.frame_bytes,
                                     spec.duration, 0, [metrics]))

    return best_rate(config, Job("udp", n, 0, search=True), run), measured


def test_the_grid_search_finds_the_minimum_of_a_unimodal_curve_in_few_runs() -> None:
    config = StudyConfig(ns=(8,), search="grid")  # share at N = 8: about 6 fps
    rates = config.rates
    for best in rates:  # wherever the minimum lies, it is found
        curve = {r: abs(rates.index(r) - rates.index(best)) + 1.0 for r in rates}
        chosen, measured = _search(config, 8, curve.__getitem__)
        assert chosen == best
        assert len(set(measured)) == len(measured)  # no rate run twice
    # near the share, a bracket of three is all it takes
    chosen, measured = _search(config, 8, lambda r: abs(r - 5.0) + 1.0)
    assert chosen == 5.0
    assert len(measured) <= 3


def test_the_fine_search_starts_at_the_share_and_ends_within_5_percent() -> None:
    """A cliff just above 4.6 fps at N = 8 (share 6 fps), AoI falling until it: the
    grid's best would be 3 fps; the fine search ends within 5 % below the cliff."""
    config = StudyConfig(ns=(8,))
    cliff = 4.6
    chosen, measured = _search(config, 8, lambda r: 1 / r if r <= cliff else 10 * r)
    assert config.share_fps(8) in measured[:2]  # and the rate 1.25 x above it
    assert cliff / 1.05 <= chosen <= cliff
    assert len(set(measured)) == len(measured) <= 12


def test_the_searched_rates_are_the_runs_but_the_fixed_one() -> None:
    """What the report lists per search: its rates in order, with their mean AoI, read
    back from the runs (the fixed-rate run and other batches, systems, N left out)."""
    config = StudyConfig(ns=(8,), batches=2)
    results = StudyResults()
    for system, n, rate, batch in (("udp", 8, 50.0, 0), ("udp", 8, 5.7, 0), ("udp", 8, 4.6, 1),
                                   ("tcp", 8, 5.7, 0), ("udp", 8, 50.0, 0), ("udp", 8, 7.1, 0),
                                   ("udp", 4, 5.7, 0)):
        results.add(RunOutcome(WifiResult(system, n, rate, 1000, 1.0, batch, [
            FollowerMetrics("uav0", rate / 10, 0.0, 0.0, 1, 1.0, 1.0)])))
    assert searched(config, results, "udp", 8, 0) == [
        (5.7, pytest.approx(0.57)), (50.0, 5.0), (7.1, pytest.approx(0.71))]
    assert searched(config, results, "udp", 8, 1) == [(4.6, pytest.approx(0.46))]


def test_the_plan_has_every_system_at_every_n() -> None:
    config = StudyConfig(ns=(2, 4), baselines=("udp", "push-block"), batches=2)
    jobs = list(plan(config))
    assert len(jobs) == 2 * 2 * (1 + 2 + 2)
    assert {(j.system, j.search) for j in jobs} == {
        ("wiswarm", False), ("udp", False), ("push-block", False), ("udp", True),
        ("push-block", True)}
    with pytest.raises(ValueError, match="baselines"):
        StudyConfig(baselines=("carrier-pigeon",))


def test_the_window_opens_with_the_age_the_run_left() -> None:
    """Run started at 0, window [10, 20]: last delivery before it was generated at 7, so
    the window opens at age 3; an update generated at 12 arrives at 14 (age 2), none after."""
    rows = {"uav0": [(8.0, 7.0), (14.0, 12.0)], "uav1": []}
    first, silent = window_metrics(rows, ["uav0", "uav1"], 0.0, 10.0, 20.0, 1000)
    area = (3 + 7) / 2 * 4 + (2 + 8) / 2 * 6
    assert first.mean_aoi_s == pytest.approx(area / 10)
    assert first.peak_aoi_s == pytest.approx(8.0)
    assert first.deliveries == 1
    assert silent.mean_aoi_s == pytest.approx(15.0)  # nothing ever came: age since start
    assert silent.deliveries == 0
