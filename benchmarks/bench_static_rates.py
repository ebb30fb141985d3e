"""Each push baseline's best fixed rate searched finely, against the paper's grid (issue 41).

A grid of whole frames per second misses a baseline's best rate, which lies just below
the cliff where its queues start to build: the gain of WiSwarm over a baseline at its
best rate is smaller measured finely. Per medium, per N, per baseline: the fine search's
best rate (``rate_search.fine_search`` from the channel's share, to 5 %), its mean AoI,
WiSwarm's, their ratio, and the grid's best rate and its ratio, a markdown table.

The simulator's ``wifi`` and ``link`` models first (udp and tcp; the cost of a rate is
the mean AoI over ``--seeds`` runs; the grid's best is the best of the whole grid), a
few minutes on two cores. With ``--testbed tbf,wifi`` (root; ns-3 for wifi) then the
stationary study on real processes, once with each search (``--search fine`` and
``grid``, the paper's walk on its grid), its baselines (``--baselines``); WiSwarm's mean
AoI there is the mean of its runs in both.

    .venv/bin/python benchmarks/bench_static_rates.py
    flock /tmp/bench.lock .venv/bin/python benchmarks/bench_static_rates.py --no-sim \\
        --testbed tbf --duration 15 --warmup 4
"""

from __future__ import annotations

import multiprocessing
import statistics
import sys
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

from study_flags import study_parser

from wiswarm_zenoh.experiments.rate_search import RateCosts, fine_search
from wiswarm_zenoh.experiments.sweep import PAPER_RATES, SweepConfig
from wiswarm_zenoh.experiments.testbed_study import (
    StudyConfig,
    StudyResults,
    run_study,
    searched,
    share_fps,
)
from wiswarm_zenoh.options import ProgressBar, UsageError, listed, one_of, require_testbed
from wiswarm_zenoh.sim.link import LinkParams, link_curve
from wiswarm_zenoh.sim.scenario import PAPER_FRAME_BYTES, WifiScenario, run_wifi
from wiswarm_zenoh.testbed.wifi_spec import WifiSpec

MODELS = ("wifi", "link")
SIM_BASELINES = ("udp", "tcp")
MEDIA = ("tbf", "wifi")


@dataclass(frozen=True)
class Row:
    """One baseline at one N: the fine search's best and the grid's, against WiSwarm."""

    medium: str
    n: int
    system: str
    share: float
    fine: float
    fine_aoi: float
    tried: int  # rates the fine search ran
    wiswarm_aoi: float
    grid: float
    grid_aoi: float


def table(rows: list[Row]) -> str:
    lines = ["| medium | N | baseline | share (fps) | fine best (fps) | its mean AoI (ms) | "
             "WiSwarm (ms) | ratio | rates tried | grid best (fps) | its mean AoI (ms) | "
             "ratio |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.medium} | {r.n} | {r.system} | {r.share:.3g} | {r.fine:.3g} | "
                     f"{r.fine_aoi * 1e3:.0f} | {r.wiswarm_aoi * 1e3:.0f} | "
                     f"{r.fine_aoi / r.wiswarm_aoi:.2f} | {r.tried} | {r.grid:g} | "
                     f"{r.grid_aoi * 1e3:.0f} | {r.grid_aoi / r.wiswarm_aoi:.2f} |")
    return "\n".join(lines)


@dataclass(frozen=True)
class SimJob:
    """A model's runs of one system at N over the seeds (``run``)."""

    model: str
    n: int
    system: str
    duration: float
    seeds: int

    def run(self, rate: float | None) -> float:
        """Mean AoI over the seeds at ``rate`` (None: WiSwarm)."""
        aoi = []
        for seed in range(self.seeds):
            result = (link_curve([self.n], [(self.system, rate)], LinkParams(),
                                 PAPER_FRAME_BYTES, self.duration, seed)[0]
                      if self.model == "link" else
                      run_wifi(WifiScenario(n=self.n, system=self.system, rate=rate or 50.0,
                                            frame_bytes=PAPER_FRAME_BYTES,
                                            duration=self.duration, seed=seed)))
            aoi.append(result.mean("mean_aoi_s"))
        return statistics.fmean(aoi)

    @property
    def share(self) -> float:
        if self.model == "link":
            return share_fps(LinkParams().rate_bps, self.n, PAPER_FRAME_BYTES)
        return SweepConfig(ns=(self.n,), rates=(1.0,), batches=1).share_fps(self.n)


def sim_search(job: SimJob) -> tuple[SimJob, float, float, int, float, float]:
    """A baseline's fine best (rate, AoI, rates run) and the whole grid's best."""
    costs = RateCosts(job.run)
    fine = fine_search(costs, job.share)
    grid = {rate: job.run(rate) for rate in PAPER_RATES}
    best = min(grid, key=grid.__getitem__)
    return job, fine, dict(costs.tried)[fine], len(costs.tried), best, grid[best]


def wiswarm_aoi(job: SimJob) -> tuple[SimJob, float]:
    return job, job.run(None)


def sim_rows(ns: tuple[int, ...], duration: float, seeds: int, jobs: int) -> list[Row]:
    wanted = [SimJob(m, n, s, duration, seeds) for m in MODELS for n in ns for s in SIM_BASELINES]
    ours = [SimJob(m, n, "wiswarm", duration, seeds) for m in MODELS for n in ns]
    with multiprocessing.get_context("spawn").Pool(jobs) as pool:
        wiswarm = {(j.model, j.n): aoi for j, aoi in pool.imap(wiswarm_aoi, ours)}
        rows = []
        for job, fine, aoi, tried, grid, grid_aoi in pool.imap(sim_search, wanted):
            rows.append(Row(job.model, job.n, job.system, job.share, fine, aoi, tried,
                            wiswarm[(job.model, job.n)], grid, grid_aoi))
            print(f"  {job.model} N={job.n} {job.system}: fine {fine:.3g} fps, grid "
                  f"{grid:g} fps", file=sys.stderr, flush=True)
    return rows


def testbed_rows(medium: str, config: StudyConfig, out: Path) -> list[Row]:
    """The study run with each search; a row per searched baseline at each N."""
    studies: dict[str, StudyResults] = {}
    for search in ("fine", "grid"):
        part = replace(config, search=search)
        studies[search] = run_study(part, out / f"{medium}-{search}",
                                    ProgressBar(f"{medium} {search}"))
    rows = []
    for n in config.ns:
        ours = [o.result.mean("mean_aoi_s") for s in studies.values() for o in s.outcomes
                if (o.result.system, o.result.n) == ("wiswarm", n)]
        for system in config.baselines:
            fine, grid = (dict(searched(config, studies[s], system, n, 0)) for s in studies)
            best = {s: studies[s].best.get((system, n, 0)) for s in studies}
            if not ours or best["fine"] is None or best["grid"] is None:
                continue  # cut short
            rows.append(Row(medium, n, system, config.share_fps(n), best["fine"],
                            fine[best["fine"]], len(fine), statistics.fmean(ours),
                            best["grid"], grid[best["grid"]]))
    return rows


def main() -> int:
    parser = study_parser(__file__, __doc__, ns=(4, 8, 14))
    parser.add_argument("--no-sim", action="store_true", help="skip the simulator's models")
    parser.add_argument("--sim-duration", type=float, default=120.0,
                        help="simulated seconds per run (default 120)")
    parser.add_argument("--seeds", type=int, default=3, help="simulator runs per rate")
    parser.add_argument("--jobs", type=int, default=2, help="simulator processes")
    parser.add_argument("--testbed", type=listed(one_of(MEDIA), "tbf,wifi"), default=(),
                        help="also the real study over these media (root)")
    parser.add_argument("--parallel", type=int, default=2, help="tbf runs at once")
    parser.add_argument("--out", type=Path, help="keep the studies' records here")
    args = parser.parse_args()
    try:
        if args.testbed:
            require_testbed()
    except UsageError as exc:
        parser.exit(2, f"{parser.prog}: {exc}\n")
    ns: tuple[int, ...] = args.ns
    rows = [] if args.no_sim else sim_rows(ns, args.sim_duration, args.seeds, args.jobs)
    if rows:
        print(f"simulator, {args.sim_duration:g} s x {args.seeds} seeds per rate:\n")
        print(table(rows) + "\n", flush=True)
    for medium in args.testbed:
        config = StudyConfig(ns=ns, baselines=args.baselines, duration=args.duration,
                             warmup=args.warmup, parallel=1 if medium == "wifi"
                             else args.parallel,
                             medium=WifiSpec(stations=max(ns)) if medium == "wifi" else None)
        with tempfile.TemporaryDirectory() as tmp:
            found = testbed_rows(medium, config, args.out or Path(tmp))
        print(f"testbed {medium}, {args.duration:g} s windows after {args.warmup:g} s:\n")
        print(table(found) + "\n", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
