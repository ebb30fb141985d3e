"""The mission benchmark's report: per medium, each system's ages phase by phase and
over the whole mission, the tuned rates and how they were found, what a weight change
did under WiSwarm, the targets, and the figure (AoI against time, phases marked)."""

from __future__ import annotations

import math
from pathlib import Path

from wiswarm_zenoh.experiments.mission import LABELS, REALIZABLE, MissionRun
from wiswarm_zenoh.experiments.mission_metrics import (
    PhaseFigures,
    age_series,
    phase_figures,
    whole,
)
from wiswarm_zenoh.experiments.mission_study import MissionResults, WeightCheck
from wiswarm_zenoh.experiments.report_cells import ms, ratio, times
from wiswarm_zenoh.experiments.ros2_air_nodes import robot_name

TARGET_WHOLE = 1.5  # every realizable system's weighted mean AoI / WiSwarm's, at least
TARGET_ORACLE = 1.2  # WiSwarm / the oracle throttle in every phase, at most
TARGET_WEIGHT_FALL = 0.30  # the raised robot's AoI falls at least this much





def _rate(run: MissionRun, phase: int) -> str:
    rate = run.rates[phase]
    return "-" if rate is None else f"{rate:.3g} Hz"


def _media(results: MissionResults) -> list[str]:
    return list(dict.fromkeys(r.medium for r in results.runs))


def summary(results: MissionResults) -> list[str]:
    """The whole mission, a row per system, a column pair per medium: its weighted mean
    AoI and that over WiSwarm's (the README's table)."""
    media = _media(results)
    systems = list(dict.fromkeys(r.system for r in results.runs))
    lines = ["| system | " + " | ".join(f"{m}: weighted mean AoI (ms) | / WiSwarm"
                                          for m in media) + " |",
             "|---|" + "---|---|" * len(media)]
    for system in systems:
        cells = []
        for medium in media:
            run, ours = results.run(medium, system), results.run(medium, "wiswarm")
            aoi = math.nan if run is None else whole(run).weighted_aoi
            base = math.nan if ours is None else whole(ours).weighted_aoi
            cells.append(f"{ms(aoi)} | {times(ratio(aoi, base))}")
        lines.append(f"| {LABELS[system]} | " + " | ".join(cells) + " |")
    return lines


def table(results: MissionResults, medium: str) -> list[str]:
    """One row per system and phase (and the whole mission): mean, p95 and weighted
    mean AoI, the throttle, the channel's bytes, and WiSwarm's weighted AoI against it."""
    runs = [r for r in results.runs if r.medium == medium]
    wiswarm = results.run(medium, "wiswarm")
    ours = [] if wiswarm is None else [*phase_figures(wiswarm), whole(wiswarm)]
    lines = ["| system | phase | robots | throttle | mean AoI (ms) | p95 AoI (ms) | "
             "weighted mean AoI (ms) | up / down (MB) | / (c) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for run in runs:
        figures = [*phase_figures(run), whole(run)]
        for index, fig in enumerate(figures):
            last = index == len(figures) - 1
            rate = "" if last else _rate(run, index)
            c = ours[index].weighted_aoi if ours else math.nan
            name = f"**{fig.name}**" if last else fig.name
            lines.append(
                f"| {LABELS[run.system]} | {name} | {len(fig.robots) if not last else ''} | "
                f"{rate} | {ms(fig.mean_aoi)} | {ms(fig.p95_aoi)} | "
                f"{ms(fig.weighted_aoi)} | {fig.up_bytes / 1e6:.0f} / "
                f"{fig.down_bytes / 1e6:.0f} | {times(ratio(fig.weighted_aoi, c))} |")
    return lines


def robot_lines(results: MissionResults, medium: str) -> list[str]:
    """Each robot's mean / p95 AoI per phase, system by system."""
    lines = []
    for run in (r for r in results.runs if r.medium == medium):
        figures = phase_figures(run)
        robots = run.mission.robots
        lines += [f"{LABELS[run.system]}:", "",
                  "| phase | " + " | ".join(robot_name(r) for r in robots) + " |",
                  "|---|" + "---|" * len(robots)]
        for fig in figures:
            cells = []
            for robot in robots:
                one = fig.robot(robot)
                cells.append("" if one is None else f"{ms(one.metrics.mean_aoi_s)} / "
                             f"{ms(one.metrics.p95_aoi_s)}")
            lines.append(f"| {fig.name} | " + " | ".join(cells) + " |")
        lines.append("")
    return lines


def tuning_lines(results: MissionResults) -> list[str]:
    """Each tuning: the rates tried, in order, with their weighted mean AoI."""
    lines = []
    for t in results.tunings:
        tried = ", ".join(f"{rate:.3g} Hz {aoi * 1e3:.0f} ms" for rate, aoi in t.tried)
        lines.append(f"- {t.medium}, {t.phase}: best {t.best:.3g} Hz ({tried})")
    return lines or ["- every rate came from tuned.json (tuned by an earlier run)"]


def weight_fall(check: WeightCheck) -> list[tuple[int, float, float, float]]:
    """Per raised robot: its AoI before and after the change, and the fall (share)."""
    out = []
    for robot in check.raised:
        before, after = check.before.robot(robot), check.after.robot(robot)
        if before is None or after is None:
            continue
        a, b = before.metrics.mean_aoi_s, after.metrics.mean_aoi_s
        out.append((robot, a, b, 1 - b / a if a > 0 else math.nan))
    return out


def _others(fig: PhaseFigures, raised: tuple[int, ...]) -> float:
    """The weighted mean AoI of the robots whose weight did not rise."""
    kept = [r for r in fig.robots if r.robot not in raised]
    total = sum(r.weight * r.seconds for r in kept)
    return sum(r.weight * r.seconds * r.metrics.mean_aoi_s for r in kept) / total \
        if total > 0 else math.nan


def weight_lines(results: MissionResults) -> list[str]:
    lines = []
    for check in results.weight_checks:
        for robot, a, b, fall in weight_fall(check):
            others = (_others(check.before, check.raised), _others(check.after, check.raised))
            lines.append(f"- {check.medium}, {check.phase}: {robot_name(robot)}'s AoI "
                         f"{ms(a)} -> {ms(b)} ms ({fall * 100:.0f} % lower) when its "
                         f"weight rose; the others' weighted AoI {ms(others[0])} -> "
                         f"{ms(others[1])} ms")
    return lines


def targets(results: MissionResults) -> list[str]:
    """Each of the issue's targets, met or missed, with its numbers."""
    lines = []
    for medium in _media(results):
        wiswarm = results.run(medium, "wiswarm")
        if wiswarm is None:
            continue
        ours = whole(wiswarm).weighted_aoi
        for system in REALIZABLE:
            other = results.run(medium, system)
            if other is None:
                continue
            gain = ratio(whole(other).weighted_aoi, ours)
            lines.append(f"- {medium}: {LABELS[system]} / WiSwarm over the mission "
                         f"{times(gain)} (target >= {TARGET_WHOLE}): "
                         f"{'met' if gain >= TARGET_WHOLE else 'MISSED'}")
        oracle = results.run(medium, "oracle")
        if oracle is not None:
            for mine, best in zip(phase_figures(wiswarm), phase_figures(oracle), strict=True):
                over = ratio(mine.weighted_aoi, best.weighted_aoi)
                lines.append(f"- {medium}, {mine.name}: WiSwarm / oracle throttle "
                             f"{times(over)} (target <= {TARGET_ORACLE}): "
                             f"{'met' if over <= TARGET_ORACLE else 'MISSED'}")
    for check in results.weight_checks:
        for robot, _, _, fall in weight_fall(check):
            lines.append(f"- {check.medium}, {check.phase}: {robot_name(robot)}'s AoI "
                         f"{fall * 100:.0f} % lower with its weight raised (target >= "
                         f"{TARGET_WEIGHT_FALL * 100:.0f} %): "
                         f"{'met' if fall >= TARGET_WEIGHT_FALL else 'MISSED'}")
    return lines


def report(results: MissionResults) -> str:
    """The markdown report."""
    out = ["## The whole mission", "", *summary(results), ""]
    for medium in _media(results):
        out += [f"## {medium}", "", *table(results, medium), "",
                f"### {medium}: each robot's mean / p95 AoI (ms)", "",
                *robot_lines(results, medium)]
    out += ["## Tuned rates", "", *tuning_lines(results), "",
            "## A weight change under WiSwarm (static runs of that phase)", "",
            *(weight_lines(results) or ["- no weight changes in this mission"]), "",
            "## Targets", "", *targets(results), ""]
    return "\n".join(out)


SYSTEM_COLOURS = {"direct": "C3", "fixed-first": "C1", "fixed-largest": "C5",
                  "oracle": "C7", "newest": "C2", "wiswarm": "C0"}


def plot(path: Path, results: MissionResults) -> None:
    """Per medium: weighted mean AoI against time, a line per system (log scale),
    the phases marked and named."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    media = _media(results)
    fig, axes = plt.subplots(len(media), 1, figsize=(11, 4.2 * len(media)), squeeze=False)
    for ax, medium in zip((row[0] for row in axes), media, strict=True):
        runs = [r for r in results.runs if r.medium == medium]
        for run in runs:
            offsets, ages = age_series(run)
            style = "-" if run.system == "wiswarm" else "--" if run.system == "oracle" else "-"
            ax.plot(offsets, [a * 1e3 for a in ages], style, color=SYSTEM_COLOURS[run.system],
                    lw=1.6 if run.system == "wiswarm" else 1.0, label=LABELS[run.system])
        ax.set_yscale("log")
        high = ax.get_ylim()[1]
        for phase in runs[0].mission.phases:
            ax.axvline(phase.start, color="k", lw=0.6, alpha=0.5)
            ax.text(phase.start + 1, high * 0.8, phase.name, fontsize=7, va="top")
        ax.set_xlim(0, runs[0].mission.duration)
        ax.set_title(f"{medium}: weighted mean AoI at the ground's ROS 2 subscriber")
        ax.set_xlabel("mission time (s)")
        ax.set_ylabel("weighted mean AoI (ms)")
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
