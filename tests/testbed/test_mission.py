"""The mission at small scale over the tbf channel (root): 2, then 3, then 2 robots,
10 s each, every system. Each flies every phase (every robot in the air delivers to the
ground's ROS 2 subscriber) and has its per-phase table; under WiSwarm the robot whose
weight rose has its age fall, with the rest of the phase as it was. The fixed rates
are given (``tuned.json``), not searched: the search has its own tests."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest

from wiswarm_zenoh.experiments.mission import LABELS, SYSTEMS, MissionConfig
from wiswarm_zenoh.experiments.mission_metrics import phase_figures
from wiswarm_zenoh.experiments.mission_report import report, weight_fall
from wiswarm_zenoh.experiments.mission_scenario import parse_mission, shipped_text
from wiswarm_zenoh.experiments.mission_study import run_study, tuning_key

pytestmark = pytest.mark.testbed
MISSION = parse_mission(tomllib.loads(shipped_text("small")), "small")
RATES = (12.0, 8.0, 12.0)  # about each phase's best on 20 Mbit/s (2, 3, 2 robots)


def _no_search(cost: object, start: float) -> float:
    raise AssertionError("every rate was given: nothing to search")


def test_every_system_flies_the_small_mission(tmp_path: Path) -> None:
    given = zip(MISSION.phases, RATES, strict=True)
    (tmp_path / "tuned.json").write_text(json.dumps(
        {tuning_key("tbf", phase): rate for phase, rate in given}))
    config = MissionConfig(MISSION, media=("tbf",), warmup=6.0, tune_seconds=8.0,
                           tune_warmup=6.0)
    results = run_study(config, tmp_path, _no_search)
    assert [run.system for run in results.runs] == list(SYSTEMS)
    for run in results.runs:
        for phase, figures in zip(MISSION.phases, phase_figures(run), strict=True):
            assert [r.robot for r in figures.robots] == list(phase.robots), run.system
            silent = [r.robot for r in figures.robots if r.metrics.deliveries < 3]
            assert not silent, (run.system, phase.name, silent)
    oracle = results.run("tbf", "oracle")
    assert oracle is not None and oracle.rates == RATES
    text = report(results)
    for system in SYSTEMS:
        assert all(f"| {LABELS[system]} | {phase.name} |" in text for phase in MISSION.phases)
    # WiSwarm's age falls after the weight change (the static runs of the last phase
    # with drone1's weight 1, then 4), and drone1 is fresher than drone2 in the mission.
    [check] = results.weight_checks
    [(robot, before, after, _)] = weight_fall(check)
    assert robot == 1 and after < before, (before, after)
    wiswarm = results.run("tbf", "wiswarm")
    assert wiswarm is not None
    last = phase_figures(wiswarm)[-1]
    one, two = last.robot(1), last.robot(2)
    assert one is not None and two is not None
    assert one.metrics.mean_aoi_s < two.metrics.mean_aoi_s, (one, two)
