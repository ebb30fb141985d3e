"""Files of the edge-cloud experiment, and the floor its hierarchy is judged against.

The floor. The cloud's age of pair i is the edge's age of follower i when the cloud's
poll samples it, plus the reply's way up (the one-way delay d and the frame's time on
the WAN), plus the time until the next fresh sample arrives. The WAN carries one frame
at a time: its own round-robin floor, with M = sites x followers pairs sharing it back
to back, is S_wan (M/2 + 1), S_wan being one frame's time on it (each delivery is
S_wan old when it lands, and comes again M S_wan later). So

    floor = (the edge's own mean AoI) + d + S_wan (M/2 + 1),

the edge's AoI measured by the edges alone (the local floor). It assumes a WAN kept
busy: one poll in flight leaves it idle for each round trip, and its floor is then
(edge) + d + S_wan + M (2d + S_wan) / 2; K = (2d + S_wan) / S_wan polls in flight close
that gap (``EdgeCloudConfig.wan_in_flight``).
"""

from __future__ import annotations

import csv
import logging
import math
from dataclasses import dataclass
from pathlib import Path

from wiswarm_zenoh.experiments.edge_cloud_run import EdgeCloudResults, SetupResult
from wiswarm_zenoh.experiments.report_cells import ms, ratio, times
from wiswarm_zenoh.testbed.run import failed_line
from wiswarm_zenoh.units import format_rate

log = logging.getLogger(__name__)

CLOSED = ("Closed (`--secure`): every node with its own certificate over TLS, every router "
          "with the access control of `wiswarm security init --site`.\n\n")
FLOOR_TARGET = 1.3  # the hierarchy's mean AoI within this of the floor
DIRECT_TARGET = 2.0  # and at least this much lower than direct polling


@dataclass(frozen=True)
class Floor:
    """The floor's terms (seconds)."""

    edge_s: float
    delay_s: float
    s_wan: float
    pairs: int

    @property
    def wan_rr_s(self) -> float:
        """The WAN's own round-robin floor, S_wan (M/2 + 1)."""
        return self.s_wan * (self.pairs / 2 + 1)

    @property
    def total_s(self) -> float:
        return self.edge_s + self.delay_s + self.wan_rr_s

    @property
    def one_in_flight_s(self) -> float:
        """The floor with one poll in flight: each poll holds the WAN for a round trip."""
        return self.edge_s + self.delay_s + self.s_wan + self.pairs * (
            2 * self.delay_s + self.s_wan) / 2


def _find(results: EdgeCloudResults, kind: str) -> SetupResult | None:
    return next((r for r in results.results if r.setup.kind == kind), None)


def floor_of(results: EdgeCloudResults) -> Floor | None:
    """The floor, from the edges-alone run (None if it was not measured)."""
    edge = _find(results, "edge")
    if edge is None:
        return None
    config = results.config
    return Floor(edge.mean("mean_aoi_s"), config.wan.delay_s,
                 config.frame_time(config.wan.rate_bps), config.pairs)





def write_csvs(out: Path, results: EdgeCloudResults, floor: Floor | None) -> list[Path]:
    """``pairs.csv`` (every pair of every setup) and ``summary.csv`` (a row a setup)."""
    pairs, summary = out / "pairs.csv", out / "summary.csv"
    with pairs.open("w", newline="") as fh:
        rows = csv.writer(fh)
        rows.writerow(["setup", "polls_in_flight", "measured_at", "pair", "mean_aoi_s",
                       "p95_aoi_s", "peak_aoi_s", "deliveries", "throughput_fps",
                       "throughput_mbps", "edge_mean_aoi_s"])
        for r in results.results:
            edge = {f.follower: f.mean_aoi_s for f in r.at_edge}
            for f in r.measured:
                rows.writerow([r.setup.label, r.setup.in_flight, _where(r), f.follower,
                               f"{f.mean_aoi_s:.6g}", f"{f.p95_aoi_s:.6g}",
                               f"{f.peak_aoi_s:.6g}", f.deliveries, f"{f.throughput_fps:.6g}",
                               f"{f.throughput_mbps:.6g}",
                               f"{edge[f.follower]:.6g}" if f.follower in edge else ""])
    direct = _find(results, "direct")
    with summary.open("w", newline="") as fh:
        rows = csv.writer(fh)
        rows.writerow(["setup", "polls_in_flight", "measured_at", "window_s", "mean_aoi_s",
                       "p95_aoi_s", "throughput_fps_per_pair", "throughput_mbps_total",
                       "wan_up_mbps", "wan_down_mbps", "edge_mean_aoi_s", "least_age_s",
                       "floor_s", "over_floor", "direct_over_this"])
        for r in results.results:
            mean = r.mean("mean_aoi_s")
            rows.writerow([
                r.setup.label, r.setup.in_flight, _where(r), f"{r.window_s:.3f}",
                f"{mean:.6g}", f"{r.mean('p95_aoi_s'):.6g}",
                f"{r.mean('throughput_fps'):.6g}",
                f"{sum(f.throughput_mbps for f in r.measured):.6g}",
                f"{r.wan_up_mbps:.6g}", f"{r.wan_down_mbps:.6g}",
                f"{r.mean('mean_aoi_s', at_edge=True):.6g}", f"{r.least_age_s:.6g}",
                "" if floor is None else f"{floor.total_s:.6g}",
                "" if floor is None else f"{ratio(mean, floor.total_s):.4g}",
                "" if direct is None else f"{ratio(direct.mean('mean_aoi_s'), mean):.4g}"])
    return [pairs, summary]


def _where(r: SetupResult) -> str:
    return "edge" if r.setup.kind == "edge" else "cloud"


def plot(path: Path, results: EdgeCloudResults, floor: Floor | None) -> None:
    """Mean and p95 AoI of every pair per setup (left), updates/s per pair (right)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (aoi, rate) = plt.subplots(1, 2, figsize=(11, 4.2))
    labels = [r.setup.label for r in results.results]
    for x, r in enumerate(results.results):
        means = [f.mean_aoi_s * 1e3 for f in r.measured]
        p95s = [f.p95_aoi_s * 1e3 for f in r.measured]
        aoi.bar(x, r.mean("mean_aoi_s") * 1e3, color="C0", alpha=0.5,
                label="mean over pairs" if x == 0 else None)
        aoi.scatter([x - 0.15] * len(means), means, s=10, color="C0",
                    label="each pair's mean" if x == 0 else None)
        aoi.scatter([x + 0.15] * len(p95s), p95s, s=10, marker="^", color="C3",
                    label="each pair's p95" if x == 0 else None)
        rate.bar(x, r.mean("throughput_fps"), color="C2", alpha=0.7)
    if floor is not None:
        aoi.axhline(floor.total_s * 1e3, color="k", linestyle="--", label="floor")
    for ax, ylabel in ((aoi, "AoI at the cloud (ms; edge alone: at the edge)"),
                       (rate, "fresh updates per second per pair")):
        ax.set_xticks(range(len(labels)), labels, rotation=20)
        ax.set_ylabel(ylabel)
        ax.grid(True, axis="y", alpha=0.3)
    aoi.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def table(results: EdgeCloudResults, floor: Floor | None) -> list[str]:
    """The markdown table: one row a setup."""
    direct = _find(results, "direct")
    lines = ["| setup | polls in flight on the WAN | mean AoI (ms) | p95 AoI (ms) | "
             "updates/s per pair | Mbit/s delivered | WAN up / down (Mbit/s) | "
             "edge's own AoI (ms) | / floor | direct / this |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in results.results:
        mean = r.mean("mean_aoi_s")
        lines.append(
            f"| {r.setup.label} | {r.setup.in_flight} | {ms(mean)} | "
            f"{ms(r.mean('p95_aoi_s'))} | {r.mean('throughput_fps'):.1f} | "
            f"{sum(f.throughput_mbps for f in r.measured):.1f} | "
            f"{r.wan_up_mbps:.1f} / {r.wan_down_mbps:.2f} | "
            f"{ms(r.mean('mean_aoi_s', at_edge=True))} | "
            f"{times(math.nan if floor is None else ratio(mean, floor.total_s))} | "
            f"{times(math.nan if direct is None else ratio(direct.mean('mean_aoi_s'), mean))} |")
    return lines


def targets(results: EdgeCloudResults, floor: Floor | None) -> list[str]:
    """Each hierarchy against the floor and against direct polling (a closed run has
    none: its cloud polls the edges only)."""
    direct = _find(results, "direct")
    lines = []
    for r in results.results:
        if r.setup.kind != "hierarchy" or floor is None:
            continue
        mean = r.mean("mean_aoi_s")
        over = ratio(mean, floor.total_s)
        line = (f"- {r.setup.label}: {ms(mean)} ms = {times(over)} x the floor (target "
                f"<= {FLOOR_TARGET:g}: {'met' if over <= FLOOR_TARGET else 'not met'})")
        if direct is not None:
            gain = ratio(direct.mean("mean_aoi_s"), mean)
            line += (f"; direct polling's is {times(gain)} x it (target >= {DIRECT_TARGET:g}: "
                     f"{'met' if gain >= DIRECT_TARGET else 'not met'})")
        elif not results.config.secure:
            continue
        lines.append(line)
    return lines or ["- not measured: the run ended before direct (but closed), a hierarchy "
                     "and the edges alone were all measured"]


def report(results: EdgeCloudResults) -> str:
    """The markdown report: setting, floor, table, targets, events."""
    config, floor = results.config, floor_of(results)
    wan = config.wan
    status = ("**Interrupted**: only the setups measured before Ctrl-C are shown.\n\n"
              if results.interrupted else "") + failed_line(
                  sum(r.failed for r in results.results), "setups")
    derivation = ["The floor is not measured: the edges-alone run is missing."]
    if floor is not None:
        derivation = [
            "Floor = the edge's own mean AoI + the one-way delay + the WAN's own "
            "round-robin floor S_wan (M/2 + 1), with S_wan one frame's time on the WAN "
            f"(headers included) and M = {floor.pairs} pairs: "
            f"{ms(floor.edge_s)} + {ms(floor.delay_s)} + {floor.s_wan * 1e3:.1f} x "
            f"({floor.pairs}/2 + 1) = **{ms(floor.total_s)} ms**. It assumes a WAN kept "
            "busy; with one poll in flight each poll holds it for a round trip "
            f"(2d + S_wan), and the floor is {ms(floor.one_in_flight_s)} ms. "
            f"(2d + S_wan) / S_wan = {(2 * floor.delay_s + floor.s_wan) / floor.s_wan:.1f} "
            "polls in flight keep it busy."]
    events = [f"- {r.setup.label}: {e}" for r in results.results for e in r.events]
    return "\n".join([
        f"# Edge and cloud: {config.sites} sites x {config.followers} followers, "
        f"{format_rate(config.local.rate_bps)} channels, WAN {format_rate(wan.rate_bps)} "
        f"and {wan.delay_s * 1e3:g} ms one way",
        "",
        f"{status}{CLOSED if config.secure else ''}Each setup: {config.warmup:g} s warm-up "
        "(from the moment every pair was "
        f"delivered), then {config.duration:g} s measured; {config.frame_bytes} B frames at "
        "100 fps into LIFO queues. AoI from the capture time every frame carries (one host "
        "clock), at the cloud (edge alone: at the edge). Polls in flight on the WAN: the "
        "cloud leader's --in-flight.",
        "",
        *derivation,
        "",
        *table(results, floor),
        "",
        "## Against the targets",
        "",
        *targets(results, floor),
        "",
        "## What happened during the runs",
        "",
        *(events or ["- nothing: every process ran to the end and stopped cleanly"]),
        "",
    ])


def write_all(out: Path, results: EdgeCloudResults) -> list[Path]:
    """Every file of the experiment into ``out``; returns their paths, the report last."""
    out.mkdir(parents=True, exist_ok=True)
    floor = floor_of(results)
    files = write_csvs(out, results, floor)
    if results.results:
        try:
            plot(out / "aoi.png", results, floor)
            files.append(out / "aoi.png")
        except Exception:  # the tables still come
            log.exception("the figure could not be drawn")
    files.append(out / "report.md")
    files[-1].write_text(report(results))
    return files
