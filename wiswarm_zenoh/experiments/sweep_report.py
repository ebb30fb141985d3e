"""Files of a sweep: CSV of every run and of the summary, figures shaped like the
paper's (Figs. 3-6), and a markdown table of WiSwarm's gains at N = 8 and N = 14."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from wiswarm_zenoh.experiments.sweep import BASELINES, METRICS, Point, SweepConfig, searched
from wiswarm_zenoh.sim.metrics import WifiResult

if TYPE_CHECKING:  # matplotlib is imported when a figure is drawn, not with the module
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

MODEL = " (model)"  # the legend's suffix of a model's curve
SEARCH_NAMES = {"fine": "the fine search (golden-section on the rate, to 5 %)",
                "grid": "the best of the grid of whole frames per second"}
SEARCH_HEAD = "share (fps) | rates tried, fps: mean AoI (ms) | best (fps) |"

# The paper's reported gains of WiSwarm (Section IV-A), where it states them.
PAPER_GAINS: dict[tuple[int, str, str], str] = {
    (8, "fixed", "mean_aoi_s"): "16x",
    (14, "udp-fixed", "mean_aoi_s"): "109x",
    (14, "tcp-fixed", "mean_aoi_s"): "48x",
    (8, "opt", "mean_aoi_s"): "1.5x",
    (14, "opt", "mean_aoi_s"): "2.2x",
    (8, "fixed", "p95_aoi_s"): "18x",
    (14, "fixed", "p95_aoi_s"): "36x",
    (8, "opt", "p95_aoi_s"): "1.2x",
    (14, "opt", "p95_aoi_s"): "1.7x",
    (8, "opt", "throughput_mbps"): "1.2x",
    (14, "opt", "throughput_mbps"): "2.7x",
}


def write_runs_csv(path: Path, results: Sequence[WifiResult],
                   events: Sequence[Sequence[str]] | None = None) -> None:
    """A row per run; with ``events`` (one list per result: what happened during a real
    run, such as a process that ended), an ``events`` column of them joined by ``; ``."""
    counters = list(dict.fromkeys(key for r in results for key in r.channel))
    notes = [] if events is None else ["events"]
    with path.open("w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["system", "n", "rate", "seed", "duration", *METRICS, *counters, *notes])
        for i, r in enumerate(results):
            out.writerow([
                r.system, r.n, "" if r.rate is None else r.rate, r.seed, r.duration,
                *(f"{r.mean(m):.6g}" for m in METRICS),
                *(f"{r.channel[c]:.6g}" if c in r.channel else "" for c in counters),
                *([] if events is None else ["; ".join(events[i])]),
            ])


def write_summary_csv(path: Path, points: Sequence[Point]) -> None:
    with path.open("w", newline="") as fh:
        out = csv.writer(fh)
        stat_names = [f"{m}_{s}" for m in METRICS for s in ("mean", "std")]
        out.writerow(["label", "n", "rate", *stat_names])
        for p in points:
            stats = [f"{v:.6g}" for m in METRICS for v in (p.mean[m], p.std[m])]
            out.writerow([p.label, p.n, "" if p.rate is None else p.rate, *stats])


def _series(points: Sequence[Point], label: str) -> list[Point]:
    return sorted((p for p in points if p.label == label), key=lambda p: p.n)


def plot_against_n(path: Path, points: Sequence[Point], metric: str, ylabel: str,
                   fixed_rate: float, log: bool, baselines: Sequence[str] = BASELINES,
                   model: Sequence[Point] = ()) -> None:
    """Two panels like the paper's: (a) fixed-rate baselines, (b) rate-optimised ones.
    ``model`` points (same labels) are drawn dashed beside the measured ones, in the
    same colour: the simulator's curve for the channel that was measured."""
    import matplotlib.pyplot as plt

    fig = figure_against_n(points, metric, ylabel, fixed_rate, log, baselines, model)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def figure_against_n(points: Sequence[Point], metric: str, ylabel: str, fixed_rate: float,
                     log: bool, baselines: Sequence[str] = BASELINES,
                     model: Sequence[Point] = ()) -> Figure:
    """``plot_against_n``'s figure. Model curves that coincide (two baselines the model
    takes for the same system at the same rate, push-block and tcp) are one line with
    both labels: drawn twice, the second would hide the first under a mixed colour that
    no legend entry names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11 if model else 10, 4.5 if model else 4),
                             sharey=log)
    panels = (
        ("(a) fixed rate", [f"{b}@{fixed_rate:g}" for b in baselines]),
        ("(b) optimised rate", [f"{b}-opt" for b in baselines]),
    )
    for ax, (title, labels) in zip(axes, panels, strict=True):
        model_lines: dict[tuple[tuple[int, float], ...], Line2D] = {}
        for label in [*labels, "wiswarm"]:
            series = _series(points, label)
            drawn = ax.errorbar([p.n for p in series], [p.mean[metric] for p in series],
                                yerr=[p.std[metric] for p in series], marker="o", capsize=3,
                                label=label)
            modelled = _series(model, label)
            curve = tuple((p.n, p.mean[metric]) for p in modelled)
            if curve in model_lines:
                line = model_lines[curve]
                line.set_label(f"{str(line.get_label()).removesuffix(MODEL)} = {label}{MODEL}")
            elif modelled:
                model_lines[curve], = ax.plot(
                    [p.n for p in modelled], [p.mean[metric] for p in modelled],
                    linestyle="--", marker="x", color=drawn.lines[0].get_color(), alpha=0.7,
                    label=f"{label}{MODEL}")
        ax.set_title(title)
        ax.set_xticks(sorted({p.n for p in points}))
        ax.set_xlabel("number of UAVs N")
        ax.set_ylabel(ylabel)
        if log:
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7 if model else None)
    fig.tight_layout()
    return fig


def plot_against_rate(path: Path, points: Sequence[Point], n: int) -> None:
    """Mean AoI of the baselines against their frame rate at one N (the paper's Fig. 3a)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 4))
    for system in BASELINES:
        series = sorted((p for p in points if p.n == n and p.label.startswith(f"{system}@")),
                        key=lambda p: p.rate or 0.0)
        ax.plot([p.rate or 0.0 for p in series], [p.mean["mean_aoi_s"] for p in series], marker="o",
                label=f"WiFi-{system.upper()}")
    for p in _series(points, "wiswarm"):
        if p.n == n:
            ax.axhline(p.mean["mean_aoi_s"], color="k", linestyle="--", label="WiSwarm (100 fps)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("frame rate per UAV (fps)")
    ax.set_ylabel("mean AoI per UAV (s)")
    ax.set_title(f"N = {n}")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# What the paper's two baselines correspond to among a Zenoh user's: reliable push is
# WiFi-TCP's delivery, best-effort push WiFi-UDP's.
PAPER_EQUIVALENT = {"push-block": "tcp", "push-drop": "udp"}


def gains_table(points: Sequence[Point], fixed_rate: float, ns: Sequence[int],
                baselines: Sequence[str] = BASELINES) -> str:
    """Markdown: baseline / WiSwarm for AoI, WiSwarm / baseline for throughput."""
    lines = [
        "| N | baseline | rate (fps) | mean AoI gain | p95 AoI gain | throughput gain "
        "| paper (mean / p95 / throughput) |",
        "|---|---|---|---|---|---|---|",
    ]
    index = {(p.label, p.n): p for p in points}
    for n in ns:
        ours = index.get(("wiswarm", n))
        if ours is None:
            continue
        for system in baselines:
            paper_system = PAPER_EQUIVALENT.get(system, system)
            for kind, label in (("fixed", f"{system}@{fixed_rate:g}"),
                                ("opt", f"{system}-opt")):
                base = index.get((label, n))
                if base is None:
                    continue
                gains = [
                    base.mean["mean_aoi_s"] / ours.mean["mean_aoi_s"],
                    base.mean["p95_aoi_s"] / ours.mean["p95_aoi_s"],
                    ours.mean["throughput_mbps"] / base.mean["throughput_mbps"]
                    if base.mean["throughput_mbps"] > 0 else math.inf,
                ]
                paper = " / ".join(
                    PAPER_GAINS.get((n, f"{paper_system}-{kind}", m),
                                    PAPER_GAINS.get((n, kind, m), "-"))
                    for m in ("mean_aoi_s", "p95_aoi_s", "throughput_mbps")
                )
                rate = f"{base.rate:g}" if base.rate is not None else "-"
                cells = " | ".join("none delivered" if math.isinf(g) else f"{g:.1f}x"
                                   for g in gains)
                lines.append(f"| {n} | {label} | {rate} | {cells} | {paper} |")
    return "\n".join(lines) + "\n"


def search_cells(share: float, tried: Sequence[tuple[float, float]], best: float | None
                 ) -> str:
    """A best-rate search's cells in a report's table (``SEARCH_HEAD``): the share it
    started from, each rate it ran in order with its mean AoI, its choice (None: it was
    cut short)."""
    runs = ", ".join(f"{rate:.3g}: {aoi * 1e3:.0f}" for rate, aoi in tried)
    return f"{share:.3g} | {runs} | {'-' if best is None else f'{best:.3g}'} |"


def search_lines(config: SweepConfig, results: Sequence[WifiResult]) -> list[str]:
    """Each baseline's search at each N: its rates in order and its choice."""
    lines = [f"| N | baseline | {SEARCH_HEAD}", "|---|---|---|---|---|"]
    for n in config.ns:
        for system in BASELINES:
            tried = searched(config, results, system, n)
            best = min(tried, key=lambda run: run[1])[0]
            lines.append(f"| {n} | {system} | "
                         f"{search_cells(config.share_fps(n), tried, best)}")
    return lines


def write_report(out: Path, config: SweepConfig, results: Sequence[WifiResult],
                 points: Sequence[Point]) -> list[Path]:
    """Write every file of the sweep into ``out``; returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    files = [out / "runs.csv", out / "summary.csv", out / "mean_aoi.png", out / "p95_aoi.png",
             out / "throughput.png"]
    write_runs_csv(files[0], results)
    write_summary_csv(files[1], points)
    plot_against_n(files[2], points, "mean_aoi_s", "mean AoI per UAV (s)", config.fixed_rate, True)
    plot_against_n(files[3], points, "p95_aoi_s", "95th percentile AoI per UAV (s)",
                   config.fixed_rate, True)
    plot_against_n(files[4], points, "throughput_mbps", "throughput per UAV (Mbit/s)",
                   config.fixed_rate, False)
    rate_n = min(config.ns, key=lambda n: abs(n - 6))  # the paper shows N = 6
    files.append(out / f"aoi_vs_rate_n{rate_n}.png")
    plot_against_rate(files[-1], points, rate_n)
    table_ns: list[int] = [n for n in (8, 14) if n in config.ns] or [max(config.ns)]
    files.append(out / "gains.md")
    header = (
        f"# WiSwarm against WiFi push baselines (simulated, {config.batches} batches of "
        f"{config.duration:g} s, {config.frame_bytes} B frames)\n\n"
        "Gain = baseline / WiSwarm for AoI, WiSwarm / baseline for throughput; "
        f"`-opt` = the rate with the lowest mean AoI at that N, by {SEARCH_NAMES[config.search]}"
        ".\n\n"
    )
    searches = "\n".join([
        "## Each baseline's best rate", "",
        f"By {SEARCH_NAMES[config.search]}; the share: 1 / (N x a lone frame's airtime), "
        "where the search starts. Mean AoI over the batches.", "",
        *search_lines(config, results), ""])
    files[-1].write_text(header + gains_table(points, config.fixed_rate, table_ns) + "\n"
                         + searches)
    return files
