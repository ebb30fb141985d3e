"""The flight study's runs and files (``wiswarm experiment tracking``; its flags and
what it does are in ``cli``): the demo over the channel for every N and system."""

from __future__ import annotations

import argparse
import csv
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from wiswarm_apps.tracking import demo
from wiswarm_apps.tracking.report import summarise
from wiswarm_zenoh.experiments import best_of_grid, share_fps
from wiswarm_zenoh.options import (
    ProgressBar,
    UsageError,
    channel_spec,
    format_rate,
    require_testbed,
    show_written,
)
from wiswarm_zenoh.testbed import ChannelSpec

SEARCH_RUNS = 3  # a typical search's runs, for the progress estimate
COLUMNS = ("system", "n", "rate_hz", "mean_tracking_error_m", "p95_tracking_error_m",
           "mean_aoi_s", "p95_aoi_s", "in_view_share")


@dataclass(frozen=True)
class Row:
    """One demo run's averages over its UAVs."""

    label: str  # wiswarm, push@50, push-opt
    n: int
    rate_hz: float
    values: dict[str, float]


class TrackingStudy:
    """Runs the demo over the channel and keeps every run's averages."""

    def __init__(self, base: demo.DemoOptions, progress: Callable[[int, int], None],
                 total: int) -> None:
        self.base = base
        self.rows: list[Row] = []
        self._progress = progress
        self._total = total

    def run(self, system: str, n: int, rate: float, label: str) -> Row:
        options = replace(self.base, uavs=n, system=system, rate_hz=rate)  # type: ignore[arg-type]
        summary = summarise(demo.run(options))
        average = summary["average"]
        assert isinstance(average, dict)
        values = {k: float(average[k]) if average.get(k) is not None else float("nan")
                  for k in COLUMNS[3:]}
        row = Row(label, n, rate, values)
        self.rows.append(row)
        self._progress(len(self.rows), max(self._total, len(self.rows)))
        return row


def run_study(study: TrackingStudy, ns: list[int], rates: tuple[float, ...],
              fixed_rate: float) -> None:
    """Every N: WiSwarm, push at ``fixed_rate``, push at its best rate by tracking error."""
    channel = study.base.channel
    assert isinstance(channel, ChannelSpec)  # the study builds a tbf channel
    frame_bytes = study.base.frame_px ** 2
    for n in ns:
        study.run("wiswarm", n, demo.DEFAULT_RATE["wiswarm"], "wiswarm")
        study.run("push", n, fixed_rate, f"push@{fixed_rate:g}")
        searched: dict[float, Row] = {}

        def error(rate: float, n: int = n, searched: dict[float, Row] = searched) -> float:
            searched[rate] = study.run("push", n, rate, f"push@{rate:g}")
            return searched[rate].values["mean_tracking_error_m"]

        best = best_of_grid(rates, share_fps(channel.rate_bps, n, frame_bytes), error)
        study.rows.append(replace(searched[best], label="push-opt"))


def write_files(out: Path, rows: list[Row], title: str, fixed_rate: float) -> list[Path]:
    """The study's files; the figures and table show WiSwarm, push at ``fixed_rate``
    and push at its best rate (``push-opt``)."""
    shown = ("wiswarm", f"push@{fixed_rate:g}", "push-opt")
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "runs.csv", out / "tracking_error.png", out / "aoi.png", out / "tracking.md"]
    with paths[0].open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(COLUMNS)
        for r in rows:
            writer.writerow([r.label, r.n, r.rate_hz, *(f"{r.values[k]:.6g}" for k in COLUMNS[3:])])
    _plot(paths[1], rows, shown, "mean_tracking_error_m", "mean tracking error (m)", title,
          log=False)
    _plot(paths[2], rows, shown, "mean_aoi_s", "mean AoI per UAV (s)", title, log=True)
    paths[3].write_text(_table(rows, shown, title))
    return paths


def _first_per_n(rows: list[Row], label: str) -> list[Row]:
    """One row per N for ``label`` (a search may have run the fixed rate again)."""
    return list({r.n: r for r in reversed(rows) if r.label == label}.values())[::-1]


def _plot(path: Path, rows: list[Row], shown: tuple[str, ...], metric: str, ylabel: str,
          title: str, log: bool) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for label in shown:
        series = sorted(_first_per_n(rows, label), key=lambda r: r.n)
        ax.plot([r.n for r in series], [r.values[metric] for r in series], marker="o",
                label=label)
    ax.set_xlabel("number of UAVs N")
    ax.set_ylabel(ylabel)
    ax.set_xticks(sorted({r.n for r in rows}))
    if log:
        ax.set_yscale("log")
    ax.set_title(title, fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _table(rows: list[Row], shown: tuple[str, ...], title: str) -> str:
    lines = [f"# {title}", "", "| N | system | rate (fps) | tracking error (m) | mean AoI (s) "
             "| error / WiSwarm's |", "|---|---|---|---|---|---|"]
    for n in sorted({r.n for r in rows}):
        ours = next((r for r in rows if r.n == n and r.label == "wiswarm"), None)
        for label in shown:
            r = next((r for r in rows if r.n == n and r.label == label), None)
            if r is None:
                continue
            ratio = (r.values["mean_tracking_error_m"] / ours.values["mean_tracking_error_m"]
                     if ours is not None and ours.values["mean_tracking_error_m"] > 0 else 0.0)
            lines.append(f"| {n} | {r.label} | {r.rate_hz:g} | "
                         f"{r.values['mean_tracking_error_m']:.3f} | "
                         f"{r.values['mean_aoi_s']:.3f} | {ratio:.1f}x |")
    return "\n".join(lines) + "\n"


def run_tracking(args: argparse.Namespace) -> int:
    """``wiswarm experiment tracking`` with the flags ``cli.register_tracking`` made."""
    channel = channel_spec(args)
    try:
        base = demo.DemoOptions(duration_s=args.duration, seed=args.seed, channel=channel,
                                frame_px=args.frame_size, dashboard_port=None)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    require_testbed()
    ns = list(args.ns)
    out: Path = args.out or Path("runs") / time.strftime("tracking-%Y%m%d-%H%M%S")
    title = (f"tracking over {format_rate(channel.rate_bps)} "
             f"({channel.queue_s * 1e3:g} ms queue), {args.duration:g} s per run")
    study = TrackingStudy(base, ProgressBar("tracking"), len(ns) * (2 + SEARCH_RUNS))
    print(f"experiment tracking: N in {ns}, output in {out}", file=sys.stderr)
    interrupted = False
    try:
        run_study(study, ns, args.rates, args.fixed_rate)
    except KeyboardInterrupt:
        interrupted = True
    return show_written(write_files(out, study.rows, title, args.fixed_rate), interrupted)
