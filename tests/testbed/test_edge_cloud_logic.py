"""The edge-cloud experiment's plan, floor and report, without building anything (no
root needed): the numbers it judges the hierarchy by, and what it writes."""

from __future__ import annotations

import contextlib
import math
import multiprocessing
from pathlib import Path

import pytest

from wiswarm_zenoh.cli import main as cli
from wiswarm_zenoh.experiments.edge_cloud_report import Floor, floor_of, report, write_all
from wiswarm_zenoh.experiments.edge_cloud_run import (
    EdgeCloudConfig,
    EdgeCloudResults,
    Layers,
    Setup,
    SetupResult,
)
from wiswarm_zenoh.experiments.edge_cloud_topology import WanSpec
from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.runners import ReadySignal, StopSignal
from wiswarm_zenoh.sim.metrics import FollowerMetrics

PAIRS = [f"s{s}.uav{i}" for i in range(6) for s in (1, 2)]


def test_the_floor_adds_the_edge_the_delay_and_the_wans_round_robin() -> None:
    floor = Floor(edge_s=0.090, delay_s=0.020, s_wan=0.008, pairs=12)
    assert floor.wan_rr_s == pytest.approx(0.008 * 7)
    assert floor.total_s == pytest.approx(0.090 + 0.020 + 0.056)
    # one poll in flight: every pair waits for M round trips of 2d + S_wan
    assert floor.one_in_flight_s == pytest.approx(0.090 + 0.020 + 0.008 + 12 * 0.048 / 2)


def test_the_default_plan_runs_one_enough_to_fill_the_wan_one_per_pair_and_auto() -> None:
    config = EdgeCloudConfig()
    s_wan = config.frame_time(50_000_000)
    assert s_wan == pytest.approx(224 * 224 * 8 * 1.04 / 50e6)
    assert config.wan_in_flight() == math.ceil((0.04 + s_wan) / s_wan) == 6
    assert [s.label for s in config.setups()] == [
        "direct", "hierarchy x1", "hierarchy x6", "hierarchy x12", "hierarchy, K auto",
        "edge alone"]
    assert [s.in_flight for s in config.setups()] == [1, 1, 6, 12, "auto", 0]
    assert EdgeCloudConfig(in_flight=(3,)).setups()[1] == Setup("hierarchy", 3)
    assert EdgeCloudConfig(sites=1, followers=2).wan_in_flight() == 2  # at most one per pair


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"sites": 0}, "sites"), ({"followers": 101}, "followers"),
    ({"in_flight": (13,)}, "in_flight"), ({"duration": math.nan}, "duration"),
    ({"warmup": 0.0}, "warmup"), ({"frame_bytes": 8}, "frame_bytes"),
])
def test_a_config_names_the_field_it_rejects(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        EdgeCloudConfig(**kwargs)  # type: ignore[arg-type]


def test_the_wan_refuses_a_delay_it_cannot_hold_and_a_rate_tbf_cannot_shape() -> None:
    for kwargs, field in (({"delay_s": 0.0}, "delay_s"), ({"delay_s": 11.0}, "delay_s"),
                          ({"rate_bps": 10}, "rate_bps")):
        with pytest.raises(ValueError, match=field):
            WanSpec(**kwargs)


def test_a_bad_combination_of_flags_is_one_line_naming_the_flag_before_anything_runs(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    def never() -> None:
        raise AssertionError("the testbed was reached")

    monkeypatch.setattr("wiswarm_zenoh.options.testbed.check_available", never)
    for flags, flag in ((["--in-flight", "1,13"], "--in-flight"),
                        (["--frame-bytes", "8"], "--frame-bytes"),
                        (["--delay", "11s"], "--delay")):
        assert cli.main(["experiment", "edge-cloud", *flags]) == 2
        lines = capsys.readouterr().err.splitlines()
        assert len(lines) == 1 and "error: " in lines[0] and flag in lines[0], lines


def _result(setup: Setup, mean_s: float, edge_s: float | None = None) -> SetupResult:
    def metrics(mean: float) -> list[FollowerMetrics]:
        return [FollowerMetrics(p, mean, 1.5 * mean, 2 * mean, 100, 10.0, 4.0)
                for p in PAIRS]
    return SetupResult(setup, 10.0, metrics(mean_s),
                       [] if edge_s is None else metrics(edge_s), 30.0, 0.3, 0.05)


def _results() -> EdgeCloudResults:
    return EdgeCloudResults(EdgeCloudConfig(), [
        _result(Setup("direct"), 0.400),
        _result(Setup("hierarchy", 1), 0.430, 0.090),
        _result(Setup("hierarchy", 6), 0.190, 0.090),
        _result(Setup("edge"), 0.090, 0.090)])


def test_the_report_judges_each_hierarchy_against_the_floor_and_direct_polling() -> None:
    results = _results()
    floor = floor_of(results)
    assert floor is not None and floor.edge_s == pytest.approx(0.090)
    text = report(results)
    assert f"= **{floor.total_s * 1e3:.0f} ms**" in text
    over = 0.190 / floor.total_s
    assert f"| hierarchy x6 | 6 | 190 | 285 | 10.0 | 48.0 | 30.0 / 0.30 | 90 | {over:.2f} | " \
           "2.11 |" in text
    assert f"- hierarchy x6: 190 ms = {over:.2f} x the floor (target <= 1.3: met); direct " \
           "polling's is 2.11 x it (target >= 2: met)" in text
    assert "- hierarchy x1: 430 ms" in text and "(target >= 2: not met)" in text


def test_an_interrupted_run_reports_what_it_has(tmp_path: Path) -> None:
    results = EdgeCloudResults(EdgeCloudConfig(), [_result(Setup("direct"), 0.400)],
                               interrupted=True)
    files = write_all(tmp_path, results)
    assert [f.name for f in files] == ["pairs.csv", "summary.csv", "aoi.png", "report.md"]
    text = files[-1].read_text()
    assert "**Interrupted**" in text and "the edges-alone run is missing" in text
    assert "- not measured" in text
    assert len((tmp_path / "pairs.csv").read_text().splitlines()) == 1 + len(PAIRS)


def test_a_setup_with_a_failed_process_says_so_first_and_in_its_events() -> None:
    failed = _result(Setup("hierarchy", 6), 0.190, 0.090)
    failed.events = ["t=3.0s, stopping: edge-s1 process failed: exit code 1"]
    failed.failed = 1
    results = _results()
    results.results[2] = failed
    text = report(results)
    assert text.split("\n\n")[1].startswith("**1 process failure(s)**")
    assert "- hierarchy x6: t=3.0s, stopping: edge-s1 process failed: exit code 1" in text
    clean = report(_results())
    assert "failure" not in clean
    assert "- nothing: every process ran to the end and stopped cleanly" in clean


def _stops_cleanly(stop: StopSignal, ready: ReadySignal) -> None:
    ready.set()
    stop.wait()


def _fails_at_its_end(stop: StopSignal, ready: ReadySignal) -> None:
    ready.set()
    stop.wait()
    raise SystemExit(3)


def test_the_setups_children_that_did_not_stop_cleanly_are_named_the_links_are_not() -> None:
    ctx = multiprocessing.get_context("spawn")
    with Children(ctx) as links:
        links.start("router", _stops_cleanly)
        with contextlib.ExitStack() as stack:
            layers = Layers(stack, links, ["router"])
            layers.start(0, "followers", _stops_cleanly)
            layers.start(1, "edge", _fails_at_its_end)
            layers.wait_ready()
        assert layers.stopped_badly() == ["edge process failed: exit code 3"]
