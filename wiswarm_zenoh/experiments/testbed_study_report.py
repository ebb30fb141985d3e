"""Files of a testbed study: CSV of every run and of the summary, the sweep's figures
with the simulator's ``link`` model of the same channel drawn beside the measurement,
and a markdown table of WiSwarm's gains next to the paper's."""

from __future__ import annotations

import logging
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

from wiswarm_zenoh.experiments.sweep import Point, point_of
from wiswarm_zenoh.experiments.sweep_report import (
    SEARCH_HEAD,
    SEARCH_NAMES,
    gains_table,
    plot_against_n,
    search_cells,
    write_runs_csv,
    write_summary_csv,
)
from wiswarm_zenoh.experiments.testbed_study import StudyConfig, StudyResults, searched
from wiswarm_zenoh.sim.link import LinkParams, link_curve
from wiswarm_zenoh.sim.metrics import WifiResult
from wiswarm_zenoh.testbed.run import ADAPTIVE, WISWARM_SAMPLE_RATE, failed_line
from wiswarm_zenoh.units import format_rate

log = logging.getLogger(__name__)

MODEL_OF = {"udp": "udp", "tcp": "tcp", "push-block": "tcp"}  # baselines the model has


def label_of(result: WifiResult) -> str:
    return result.system if result.rate is None else f"{result.system}@{result.rate:g}"


def summarise(config: StudyConfig, results: StudyResults) -> list[Point]:
    """A point per (label, N) over the batches, and ``<baseline>-opt`` at the rate its
    search chose (or the best measured so far, if the study was cut short). Newest only
    has no rate to choose: it adapts, so its one run, at the camera's rate, is its
    ``-opt`` too (drawn and tabled beside the others' best)."""
    groups: dict[tuple[str, int], list[WifiResult]] = defaultdict(list)
    for outcome in results.outcomes:
        groups[(label_of(outcome.result), outcome.result.n)].append(outcome.result)
    points = [point_of(label, group) for (label, _), group in sorted(groups.items())]
    for n in config.ns:
        for system in config.baselines:
            if system in ADAPTIVE:
                points += [Point(f"{system}-opt", n, p.rate, p.mean, p.std) for p in points
                           if p.n == n and p.label == f"{system}@{WISWARM_SAMPLE_RATE:g}"]
                continue
            tried = {rate for b in range(config.batches)
                     for rate, _ in searched(config, results, system, n, b)}
            rates = [p for p in points if p.n == n and p.label.startswith(f"{system}@")
                     and p.rate in tried]
            chosen = [results.best[(system, n, b)] for b in range(config.batches)
                      if (system, n, b) in results.best]
            if chosen:
                rates = [p for p in rates if p.rate in chosen] or rates
            if rates:
                best = min(rates, key=lambda p: p.mean["mean_aoi_s"])
                points.append(Point(f"{system}-opt", n, best.rate, best.mean, best.std))
    return points


def model_points(config: StudyConfig, points: Sequence[Point]) -> list[Point]:
    """The simulator's ``link`` model of the channel, for WiSwarm and for the baselines
    it models, at the rates that were measured (``-opt`` at the rate the search chose),
    each run as long as a measured run (warm-up and window): a push baseline's queue,
    and so its age, grows with the run's length. None for the WiFi medium: ns-3 is the
    model there (``bench_wifi.py`` sets ours beside it)."""
    if config.medium is not None:
        return []
    link = LinkParams(rate_bps=config.channel.rate_bps, down_rate_bps=config.channel.down_bps,
                      queue_s=config.channel.queue_s, burst_bytes=config.channel.burst_bytes)
    modelled: list[Point] = []
    for n in sorted({p.n for p in points}):
        wanted: dict[str, tuple[str, float | None]] = {"wiswarm": ("wiswarm", None)}
        for p in points:
            system = p.label.split("@")[0].removesuffix("-opt")
            if p.n == n and system in MODEL_OF and p.rate is not None:
                wanted[p.label] = (MODEL_OF[system], p.rate)
        keys = list(dict.fromkeys(wanted.values()))
        runs = dict(zip(keys, link_curve([n], keys, link, config.frame_bytes,
                                         config.warmup + config.duration, seed=0), strict=True))
        for label, key in wanted.items():
            result = runs.get(key)
            if result is not None:
                modelled.append(point_of(label, [result]))
    return modelled


def search_lines(config: StudyConfig, results: StudyResults) -> list[str]:
    """Each search: the rates it ran in order with their mean AoI, and its choice."""
    lines = [f"| N | baseline | batch | {SEARCH_HEAD}", "|---|---|---|---|---|---|"]
    for n in config.ns:
        for system in (s for s in config.baselines if s not in ADAPTIVE):
            for batch in range(config.batches):
                tried = searched(config, results, system, n, batch)
                if not tried:
                    continue
                lines.append(f"| {n} | {system} | {batch} | " + search_cells(
                    config.share_fps(n), tried, results.best.get((system, n, batch))))
    return lines


def floor_lines(results: StudyResults) -> list[str]:
    """WiSwarm's mean AoI against the round-robin floor S (N/2 + 1), S measured: the
    window over the polls that delivered (every poll finds a fresh frame at 100 fps)."""
    lines = ["| N | S measured (ms) | floor S(N/2+1) (ms) | WiSwarm mean AoI (ms) | ratio |",
             "|---|---|---|---|---|"]
    for outcome in sorted(results.outcomes, key=lambda o: o.result.n):
        r = outcome.result
        deliveries = sum(f.deliveries for f in r.followers)
        if r.system != "wiswarm" or not deliveries:
            continue
        s = r.duration / deliveries
        floor = s * (r.n / 2 + 1)
        mean = r.mean("mean_aoi_s")
        lines.append(f"| {r.n} | {s * 1e3:.1f} | {floor * 1e3:.0f} | {mean * 1e3:.0f} | "
                     f"{mean / floor:.2f} |")
    return lines


MEDIUM_COLUMNS = (("failed_tx_share", "failed tx share", 1.0, ".3f"),
                  ("retry_drops", "retry drops", 1.0, ".0f"),
                  ("queue_drops", "queue drops", 1.0, ".0f"),
                  ("airtime_share", "airtime", 1.0, ".2f"),
                  ("max_lag_ms", "largest lag yet (ms)", 1.0, ".1f"))


def medium_lines(results: StudyResults) -> list[str]:
    """The WiFi medium's own counters per run: what the air did with each system."""
    head = " | ".join(title for _, title, _, _ in MEDIUM_COLUMNS)
    lines = [f"| run | N | {head} |", "|---|---|" + "---|" * len(MEDIUM_COLUMNS)]
    for outcome in sorted(results.outcomes, key=lambda o: (o.result.n, label_of(o.result))):
        r = outcome.result
        cells = " | ".join(format(r.channel.get(key, 0.0) * scale, spec)
                           for key, _, scale, spec in MEDIUM_COLUMNS)
        lines.append(f"| {label_of(r)} | {r.n} | {cells} |")
    return lines


def write_study(out: Path, config: StudyConfig, results: StudyResults) -> list[Path]:
    """Write every file of the study into ``out``; returns their paths (report last)."""
    out.mkdir(parents=True, exist_ok=True)
    points = summarise(config, results)
    files = [out / "runs.csv", out / "summary.csv"]
    ordered = sorted(results.outcomes, key=lambda o: (o.result.n, label_of(o.result)))
    write_runs_csv(files[0], [o.result for o in ordered], [o.events for o in ordered])
    write_summary_csv(files[1], points)
    if not points:
        return files
    try:
        model = model_points(config, points)
    except Exception:  # the figures still come, without the model beside them
        log.exception("the link model could not be drawn")
        model = []
    for name, metric, ylabel, log_scale in (
        ("mean_aoi.png", "mean_aoi_s", "mean AoI per UAV (s)", True),
        ("p95_aoi.png", "p95_aoi_s", "95th percentile AoI per UAV (s)", True),
        ("throughput.png", "throughput_mbps", "throughput per UAV (Mbit/s)", False),
    ):
        files.append(out / name)
        plot_against_n(files[-1], points, metric, ylabel, config.fixed_rate, log_scale,
                       config.baselines, model)
    files.append(out / "gains.md")
    files[-1].write_text(_report_text(config, results, points))
    return files


def _report_text(config: StudyConfig, results: StudyResults, points: Sequence[Point]) -> str:
    ch = config.channel
    ns: list[int] = [n for n in (8, 14) if n in config.ns] or [max(config.ns)]
    status = ("**Interrupted**: the figures cover the runs measured before Ctrl-C.\n\n"
              if results.interrupted else "") + failed_line(
                  sum(o.failed for o in results.outcomes), "runs")
    events = [f"- {label_of(o.result)} N={o.result.n}: {e}"
              for o in results.outcomes for e in o.events]
    medium = (f"an emulated channel ({format_rate(ch.rate_bps)} up, "
              f"{format_rate(ch.down_bps)} down, {ch.queue_s * 1e3:g} ms tbf queue)"
              if config.medium is None else
              f"the WiFi medium ({config.medium.describe()}, a station per follower)")
    air = [] if config.medium is None else [
        "## The air (ns-3's counters over each run's window)", "",
        "Failed tx share: transmissions whose acknowledgement never came (collisions, "
        "errors) among all; retry drops: frames given up after the retry limit; queue "
        "drops: frames the stations' full MAC queues refused; airtime: every node's "
        "transmit time over the window (above 1 when transmissions overlap); largest lag: of "
        "the simulation behind real time, since the medium was built (every run before "
        "on it included).", "",
        *medium_lines(results), ""]
    return "\n".join([
        f"# WiSwarm against push baselines on real processes over {medium}",
        "",
        f"{status}{config.batches} batch(es) of {config.duration:g} s after a "
        f"{config.warmup:g} s warm-up, {config.frame_bytes} B frames. Gain = baseline / "
        "WiSwarm for AoI, WiSwarm / baseline for throughput; `-opt` = the rate "
        f"{SEARCH_NAMES[config.search]} found best at that N; newest only (`-newest`: "
        "each robot's newest frame, sent once its previous send completed) adapts, so "
        f"it runs once, at the camera's {WISWARM_SAMPLE_RATE:g} fps, and that run is its "
        "`-opt`. AoI from the generation time every frame carries (one host clock).",
        "",
        gains_table(points, config.fixed_rate, ns, config.baselines),
        "## Each baseline's best rate",
        "",
        f"Found by {SEARCH_NAMES[config.search]}, starting from the channel's share of "
        "each follower (`-` : the search was cut short).",
        "",
        *search_lines(config, results),
        "",
        "## WiSwarm against the round-robin floor",
        "",
        *floor_lines(results),
        "",
        *air,
        "## What happened during the runs",
        "",
        *(events or ["- nothing: every process ran to the end and stopped cleanly, the "
                     "channel's rate did not change"]),
        "",
    ])
