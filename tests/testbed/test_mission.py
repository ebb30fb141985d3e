"""The mission at small scale over the tbf channel (root): 2, then 3, then 2 robots,
10 s each, every system. Each flies every phase (every robot in the air delivers to the
ground's ROS 2 subscriber) and has its per-phase table; the weight change is flown
statically under WiSwarm before and after (its effect is the benchmark's figure). The fixed rates
are given (``tuned.json``), not searched: the search has its own tests."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest

from wiswarm_zenoh.experiments.mission import LABELS, SYSTEMS, MissionConfig
from wiswarm_zenoh.experiments.mission_metrics import phase_figures
from wiswarm_zenoh.experiments.mission_report import report
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
    # The weight change is measured by two static runs of the last phase under WiSwarm
    # (drone1's weight 1, then 4). Whether its age falls is the benchmark's figure, not
    # asserted here: with 30 Hz cameras at N = 2 the leader already takes nearly every
    # frame of each, so the weight has little to move (a fresh clone's run: 45 -> 50 ms).
    [check] = results.weight_checks
    assert check.raised == (1,)
    assert [r.robot for r in check.before.robots] == [r.robot for r in check.after.robots] \
        == [1, 2]
    assert all(r.metrics.deliveries >= 3 for r in (*check.before.robots, *check.after.robots))
