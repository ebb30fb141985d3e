"""The mission benchmark's pieces that need no root: the scenario file and its errors,
the weights the operator puts, the WiFi rate of a degraded link, the figures of a run,
and the report."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from wiswarm_zenoh.experiments.mission import MissionRun, Stint, degraded_mode, weight_puts
from wiswarm_zenoh.experiments.mission_metrics import age_series, phase_figures, whole
from wiswarm_zenoh.experiments.mission_report import plot, report
from wiswarm_zenoh.experiments.mission_scenario import (
    Phase,
    load_mission,
    parse_mission,
    shipped_text,
)
from wiswarm_zenoh.experiments.mission_study import (
    MissionResults,
    first_weight_change,
    rates_for,
)
from wiswarm_zenoh.testbed.wifi_spec import WifiSpec


def test_the_standard_mission_is_the_issues_four_phases() -> None:
    mission = parse_mission(tomllib.loads(shipped_text("standard")))
    assert [len(p.robots) for p in mission.phases] == [4, 8, 8, 3]
    assert [p.start for p in mission.phases] == [0, 60, 120, 180] and mission.duration == 240
    third, fourth = mission.phases[2], mission.phases[3]
    assert third.link_of(2) == 0.25 and third.link_of(1) == 1.0
    assert fourth.link_of(2) == 0.25  # a setting holds until another phase changes it
    assert fourth.weight_of(1) == 4.0 and third.weight_of(1) == 1.0
    assert mission.largest() is mission.phases[1]


def test_robots_are_a_count_or_names() -> None:
    mission = parse_mission({"phase": [{"seconds": 5, "robots": ["drone3", "drone1"]},
                                       {"seconds": 5, "robots": 2}]})
    assert [p.robots for p in mission.phases] == [(1, 3), (1, 2)]
    assert mission.robots == (1, 2, 3)


@pytest.mark.parametrize(("text", "error"), [
    ("[[phase]]\nseconds = 5\nrobots = 0\n", "phase 1.robots must be 1 .. 30, got 0"),
    ("[[phase]]\nseconds = 5\nrobots = []\n", "phase 1.robots must be a count"),
    ("[[phase]]\nseconds = 5\n", "phase 1 has no robots"),
    ("[[phase]]\nseconds = -1\nrobots = 2\n", "phase 1.seconds must be a number > 0"),
    ("[[phase]]\nseconds = 5\nrobots = [\"drone1\", \"robot2\"]\n", "unknown robot 'robot2'"),
    ("[[phase]]\nseconds = 5\nrobots = 2\nweight = { drone3 = 2 }\n",
     "phase 1.weight: drone3 does not fly in this phase"),
    ("[[phase]]\nseconds = 5\nrobots = 2\nlink = { drone1 = 2 }\n",
     "phase 1.link.drone1 must be at most 1"),
    ("[[phase]]\nseconds = 5\nrobots = 2\nweight = { drone1 = -4 }\n",
     "phase 1.weight.drone1 must be a number > 0"),
    ("[[phase]]\nseconds = 5\nrobots = 2\nspeed = 3\n", "phase 1: unknown field 'speed'"),
    ("name = \"x\"\n", "a mission needs at least one [[phase]]"),
    ("[[phase]\n", "Expected"),
])
def test_a_bad_scenario_is_named_in_one_line(tmp_path: Path, text: str, error: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=None) as raised:
        load_mission(path)
    assert str(raised.value).startswith(f"{path}: ") and error in str(raised.value)
    assert "\n" not in str(raised.value)


def test_the_cli_refuses_a_bad_scenario_in_one_line_with_exit_2(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text("[[phase]]\nseconds = 10\nrobots = 2\nweight = { drone5 = 4 }\n")
    done = subprocess.run([sys.executable, "-m", "wiswarm_zenoh.cli.main", "experiment",
                           "mission", "--scenario", str(path)], capture_output=True,
                          text=True, check=False)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        f"wiswarm experiment mission: error: argument --scenario: {path}: phase 1.weight: "
        "drone5 does not fly in this phase"]


def test_show_scenario_prints_a_file_that_loads(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "wiswarm_zenoh.cli.main", "experiment",
                           "mission", "--show-scenario"], capture_output=True, text=True,
                          check=True)
    path = tmp_path / "mine.toml"
    path.write_text(done.stdout)
    assert load_mission(path).duration == 240


def test_weights_are_put_when_they_change_and_again_while_a_joiner_comes_up() -> None:
    mission = parse_mission(tomllib.loads(shipped_text("standard")))
    puts = weight_puts(mission, 1000.0)
    assert puts == ((1180.0, "wiswarm/air/d1/weight", "4"), (1182.0, "wiswarm/air/d1/weight", "4"),
                    (1185.0, "wiswarm/air/d1/weight", "4"))


def test_a_degraded_wifi_link_steps_down_to_the_rate_that_fits() -> None:
    assert degraded_mode(WifiSpec(), 0.25) == "ErpOfdmRate6Mbps"  # 24 -> 6 Mbit/s
    assert degraded_mode(WifiSpec(), 0.5) == "ErpOfdmRate12Mbps"
    assert degraded_mode(WifiSpec(), 0.1) == "ErpOfdmRate6Mbps"  # none fits: the lowest
    assert degraded_mode(WifiSpec(standard="80211n"), 0.25) == "HtMcs1"  # 65 -> 13


def test_the_fixed_rates_come_from_the_phases_they_are_tuned_for() -> None:
    mission = parse_mission(tomllib.loads(shipped_text("standard")))

    def tune(phase: Phase) -> float:  # phase k's rate is k
        return float(mission.phases.index(phase) + 1)

    assert rates_for("fixed-first", mission, tune) == [1.0] * 4
    assert rates_for("fixed-largest", mission, tune) == [2.0] * 4  # the first with 8 robots
    assert rates_for("oracle", mission, tune) == [1.0, 2.0, 3.0, 4.0]
    assert rates_for("wiswarm", mission, tune) == [None] * 4
    before, after = first_weight_change(mission) or (None, None)
    assert after is mission.phases[3] and before is not None
    assert before.weight_of(1) == 1.0 and before.robots == after.robots
    assert before.link_of(2) == 0.25


def _run() -> MissionRun:
    """Two phases of 10 s: drone1 alone, then drone2 joins (at 10.5 s) with weight 3.
    drone1's frames, made 0.1 s before each arrives, come every second; drone2's once,
    at 15 s, generated at 14.5 s."""
    mission = parse_mission({"phase": [
        {"seconds": 10, "robots": 1}, {"seconds": 10, "robots": 2, "weight": {"drone2": 3}}]})
    frames = {"drone1": [(t + 0.1, float(t)) for t in range(100, 120)],
              "drone2": [(115.0, 114.5)]}
    return MissionRun("tbf", "wiswarm", mission, 100.0, (None, None), frames,
                      [Stint(1, 99.0, 120.5), Stint(2, 110.5, 120.5)],
                      [(0, 0), (1_000_000, 10_000), (3_000_000, 30_000)])


def test_a_runs_figures_count_each_robot_from_its_take_off() -> None:
    first, second = phase_figures(_run())
    assert [r.robot for r in first.robots] == [1] and first.up_bytes == 1_000_000
    drone2 = second.robot(2)
    assert drone2 is not None and drone2.weight == 3.0 and drone2.seconds == pytest.approx(9.5)
    # from 110.5 (take-off, age 0) to 115 its age grows to 4.5; then from 0.5 to 5.5
    expected = (4.5 ** 2 / 2 + (0.5 + 5.5) / 2 * 5) / 9.5
    assert drone2.metrics.mean_aoi_s == pytest.approx(expected, rel=1e-6)
    drone1 = second.robot(1)
    assert drone1 is not None and drone1.metrics.mean_aoi_s == pytest.approx(0.6, abs=0.05)
    assert second.weighted_aoi == pytest.approx(
        (drone1.metrics.mean_aoi_s * 10 + 3 * expected * 9.5) / (10 + 3 * 9.5), rel=1e-6)
    assert whole(_run()).up_bytes == 3_000_000


def test_the_age_series_follows_the_freshest_frame() -> None:
    times, ages = age_series(_run())
    assert times[0] == 0.0 and ages[0] == pytest.approx(1.0)  # nothing yet: from take-off
    # at 112 s: drone1's frame of 112 s arrives at 112.1, so the freshest is 111's (1 s);
    # drone2 took off at 110.5 and nothing of it came yet (1.5 s), with weight 3
    assert ages[times.index(12.0)] == pytest.approx((1.0 * 1 + 1.5 * 3) / 4)


def test_the_report_and_figure_are_written(tmp_path: Path) -> None:
    results = MissionResults(runs=[_run()])
    text = report(results)
    assert "| (c) WiSwarm | phase 1 | 1 |" in text and "**whole mission**" in text
    plot(tmp_path / "mission.png", results)
    assert (tmp_path / "mission.png").stat().st_size > 10_000
