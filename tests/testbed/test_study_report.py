"""The testbed study's files, without a channel: its figure's legend names every line
drawn, and its report and runs.csv say when a process ended with an error."""

from __future__ import annotations

import csv
from pathlib import Path

from matplotlib.container import ErrorbarContainer

from wiswarm_zenoh.experiments.sweep import METRICS, Point
from wiswarm_zenoh.experiments.sweep_report import figure_against_n
from wiswarm_zenoh.experiments.testbed_study import StudyConfig, StudyResults
from wiswarm_zenoh.experiments.testbed_study_report import write_study
from wiswarm_zenoh.sim.metrics import FollowerMetrics, WifiResult
from wiswarm_zenoh.testbed.run import RunOutcome, ending

SYSTEMS = ("push-block", "push-drop", "udp", "tcp")


def _point(label: str, n: int, rate: float | None, aoi: float) -> Point:
    return Point(label, n, rate, dict.fromkeys(METRICS, aoi), dict.fromkeys(METRICS, 0.0))


def test_every_line_of_the_figure_has_a_legend_entry() -> None:
    """The link model takes push-block for TCP: at the same rate their model curves are
    the same line, which must be drawn once under both names, not twice under a mixed
    colour that the legend names neither; push-drop has no model, so no dashed line."""
    points, model = [], []
    for n in (2, 8):
        points.append(_point("wiswarm", n, None, 0.05 * n))
        model.append(_point("wiswarm", n, None, 0.05 * n))
        for i, system in enumerate(SYSTEMS):
            for label in (f"{system}@50", f"{system}-opt"):
                points.append(_point(label, n, 50.0, 1.0 + i + n))
        for label in ("push-block@50", "tcp@50", "udp@50", "push-block-opt", "tcp-opt"):
            model.append(_point(label, n, 50.0, 10.0 * n + (label == "udp@50")))
    fig = figure_against_n(points, "mean_aoi_s", "AoI", 50.0, True, SYSTEMS, model)
    model_lines = []
    for ax in fig.axes:
        legend = {text.get_text() for text in ax.get_legend().get_texts()}
        in_bars = {id(line) for c in ax.containers if isinstance(c, ErrorbarContainer)
                   for line in c.lines[:1]}
        bars = {c.get_label() for c in ax.containers if isinstance(c, ErrorbarContainer)}
        dashed = [line for line in ax.lines if line.get_linestyle() == "--"]
        assert bars <= legend
        assert {str(line.get_label()) for line in dashed} <= legend
        curves = [tuple(line.get_ydata()) for line in ax.lines
                  if id(line) not in in_bars and line.get_linestyle() == "--"]
        assert len(curves) == len(set(curves)), "two model lines drawn on top of each other"
        model_lines.append(len(dashed))
    assert model_lines == [3, 2]  # push-block = tcp, udp (at 50 fps only), wiswarm
    first, second = fig.axes
    assert "push-block@50 = tcp@50 (model)" in {t.get_text() for t in
                                                 first.get_legend().get_texts()}
    assert "push-block-opt = tcp-opt (model)" in {t.get_text() for t in
                                                   second.get_legend().get_texts()}


def _outcome(system: str, events: list[str]) -> RunOutcome:
    metrics = FollowerMetrics("uav0", 0.05, 0.08, 0.1, 100, 50.0, 20.0)
    return RunOutcome(WifiResult(system, 2, 50.0 if system != "wiswarm" else None, 50_176,
                                 1.0, 0, [metrics]), events, failed=len(events))


def test_the_report_and_runs_csv_say_which_process_failed(tmp_path: Path
                                                                         ) -> None:
    config = StudyConfig(ns=(2,), baselines=("push-block",), duration=1.0, warmup=0.5)
    failed = f"t=2.1s, stopping: {ending('followers', 1)}"
    results = StudyResults([_outcome("wiswarm", []), _outcome("push-block", [failed])])
    files = write_study(tmp_path / "failed", config, results)
    report = files[-1].read_text()
    assert f"- push-block@50 N=2: {failed}" in report
    assert "nothing" not in report.split("What happened during the runs")[1]
    assert "**1 process failure(s)**" in report.split("## ")[0]  # before any figure
    with files[0].open(newline="") as src:
        events = {row["system"]: row["events"] for row in csv.DictReader(src)}
    assert events == {"wiswarm": "", "push-block": failed}

    clean = StudyResults([_outcome("wiswarm", []), _outcome("push-block", [])])
    report = write_study(tmp_path / "clean", config, clean)[-1].read_text()
    assert "- nothing: every process ran to the end and stopped cleanly" in report
    assert "failure" not in report


def test_a_process_that_ended_early_or_not_cleanly_is_named_as_failed() -> None:
    assert ending("leader", 1) == "leader process failed: exit code 1"
    assert ending("leader", -9) == "leader process failed: killed by signal 9"
    assert ending("leader", 0, early=True) == \
        "leader process failed: it ended during the run (exit code 0)"
