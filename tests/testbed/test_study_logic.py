"""The study's own logic, without a channel: the best-rate search and the window's AoI."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.experiments.testbed_study import Job, StudyConfig, best_rate, plan
from wiswarm_zenoh.sim.metrics import FollowerMetrics, WifiResult
from wiswarm_zenoh.testbed.run import RunOutcome, RunSpec, window_metrics


def _search(config: StudyConfig, n: int, aoi_of_rate: dict[float, float]
            ) -> tuple[float, list[float]]:
    """The search's choice, and the rates it measured, against a known AoI curve."""
    measured: list[float] = []

    def run(spec: RunSpec) -> RunOutcome:
        measured.append(spec.rate)
        metrics = FollowerMetrics("uav0", aoi_of_rate[spec.rate], 0.0, 0.0, 1, 1.0, 1.0)
        return RunOutcome(WifiResult(spec.system, n, spec.rate, spec.frame_bytes,
                                     spec.duration, 0, [metrics]))

    return best_rate(config, Job("udp", n, 0, search=True), run), measured


def test_the_search_finds_the_minimum_of_a_unimodal_curve_in_few_runs() -> None:
    config = StudyConfig(ns=(8,))  # share at N = 8: about 6 fps
    rates = config.rates
    for best in rates:  # wherever the minimum lies, it is found
        curve = {r: abs(rates.index(r) - rates.index(best)) + 1.0 for r in rates}
        chosen, measured = _search(config, 8, curve)
        assert chosen == best
        assert len(set(measured)) == len(measured)  # no rate run twice
    # near the share, a bracket of three is all it takes
    curve = {r: abs(r - 5.0) + 1.0 for r in rates}
    chosen, measured = _search(config, 8, curve)
    assert chosen == 5.0
    assert len(measured) <= 3


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
