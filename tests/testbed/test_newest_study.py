"""Newest only in the testbed study, without a channel: it runs once per N, at the
camera's rate, never searched (it has no rate to choose), and its run is its ``-opt``
in the report, beside the other baselines' best rates."""

from __future__ import annotations

from pathlib import Path

from wiswarm_zenoh.experiments.testbed_study import (
    BASELINES,
    SEARCH_RUNS,
    StudyConfig,
    StudyResults,
    plan,
)
from wiswarm_zenoh.experiments.testbed_study_report import summarise, write_study
from wiswarm_zenoh.sim.metrics import FollowerMetrics, WifiResult
from wiswarm_zenoh.testbed.run import WISWARM_SAMPLE_RATE, RunOutcome


def test_newest_only_runs_once_at_the_camera_rate_and_is_never_searched() -> None:
    assert {"push-newest", "tcp-newest"} <= set(BASELINES)
    config = StudyConfig(ns=(4,), baselines=("udp", "push-newest", "tcp-newest"))
    jobs = [(j.system, j.search, j.rate) for j in plan(config)]
    assert jobs == [("wiswarm", False, None), ("udp", False, 50.0),
                    ("push-newest", False, None), ("tcp-newest", False, None),
                    ("udp", True, None)]
    spec = config.spec("push-newest", 4, None, 0)
    assert (spec.rate, spec.label) == (WISWARM_SAMPLE_RATE, "push-newest@100")
    assert config.estimated_runs == 1 + 3 + SEARCH_RUNS["fine"]  # one search: udp's


def _outcome(system: str, rate: float | None, aoi: float) -> RunOutcome:
    follower = FollowerMetrics("uav0", aoi, aoi, aoi, 10, 1.0, 1.0)
    return RunOutcome(WifiResult(system, 4, rate, 1000, 10.0, 0, [follower]))


def test_its_run_is_its_opt_point_and_it_has_no_search_line(tmp_path: Path) -> None:
    config = StudyConfig(ns=(4,), baselines=("udp", "push-newest"))
    results = StudyResults()
    for system, rate, aoi in (("wiswarm", None, 0.1), ("udp", 50.0, 3.0), ("udp", 5.0, 0.4),
                              ("push-newest", WISWARM_SAMPLE_RATE, 0.25)):
        results.add(_outcome(system, rate, aoi))
    results.best[("udp", 4, 0)] = 5.0
    points = {(p.label, p.rate): p.mean["mean_aoi_s"] for p in summarise(config, results)}
    assert points[("push-newest-opt", WISWARM_SAMPLE_RATE)] == 0.25
    assert points[("udp-opt", 5.0)] == 0.4
    report = write_study(tmp_path, config, results)[-1].read_text()
    assert "| 4 | push-newest-opt | 100 | 2.5x |" in report
    assert "| 4 | udp | 0 |" in report and "| 4 | push-newest | 0 |" not in report
