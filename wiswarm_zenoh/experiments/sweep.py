"""The paper's stationary study (Section IV-A) over the ``wifi`` channel.

For every N: WiSwarm, and WiFi-UDP / WiFi-TCP pushing at every rate of the grid, each
in ``batches`` independent batches. A batch uses the same seed for every system and N,
so all systems see the same links. The rate-optimised baselines take, for each N, the
rate with the lowest mean AoI over the batches (the paper picked by tracking error,
which the simulator does not model); the fixed-rate ones take ``fixed_rate``. That rate
is found by ``search``: ``fine`` (the default), ``rate_search.fine_search`` from the
air's share of each follower, 1 / (N x a frame's airtime), until the best rate's tried
neighbours are within 5 %, its cost the mean AoI over the batches; or ``grid``, the
paper's, the best of the grid. The grid is run either way (the AoI against rate figure).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import statistics
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial
from typing import TypeVar

from wiswarm_zenoh.experiments.rate_search import fine_search
from wiswarm_zenoh.sim.metrics import WifiResult
from wiswarm_zenoh.sim.phy import Airtime, WifiParams
from wiswarm_zenoh.sim.scenario import PAPER_FRAME_BYTES, WifiScenario, run_wifi

PAPER_RATES = (1.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 25.0, 50.0, 100.0)
PAPER_NS = (2, 4, 6, 8, 10, 12, 14)
BASELINES = ("udp", "tcp")
METRICS = ("mean_aoi_s", "p95_aoi_s", "peak_aoi_s", "throughput_fps", "throughput_mbps")
SEARCHES = ("fine", "grid")  # how a study finds a baseline's best rate (see the module)
FINE_SEARCH_RUNS = 7  # a fine search's typical rates, for the progress estimates
T = TypeVar("T")
R = TypeVar("R")


def check_study(ns: tuple[int, ...], rates: tuple[float, ...], batches: int,
                search: str) -> None:
    """What every study of N and rate needs (ValueError names the field)."""
    if search not in SEARCHES:
        raise ValueError(f"search must be one of {', '.join(SEARCHES)}, got {search!r}")
    if not ns or min(ns) < 1:
        raise ValueError("ns must be a non-empty list of integers >= 1")
    if not rates or min(rates) <= 0:
        raise ValueError("rates must be a non-empty list of numbers > 0")
    if batches < 1:
        raise ValueError(f"batches must be >= 1, got {batches}")


@dataclass(frozen=True)
class SweepConfig:
    """What to sweep; validated on construction (ValueError)."""

    ns: tuple[int, ...] = PAPER_NS
    rates: tuple[float, ...] = PAPER_RATES
    fixed_rate: float = 50.0
    batches: int = 4
    duration: float = 240.0
    seed: int = 0
    frame_bytes: int = PAPER_FRAME_BYTES
    search: str = "fine"

    def __post_init__(self) -> None:
        check_study(self.ns, self.rates, self.batches, self.search)
        self.plan()  # every scenario validates itself

    def share_fps(self, n: int) -> float:
        """Frames per second per follower that the air carries when N share it, from a
        lone frame's airtime: where the search starts (collisions and retries take more
        of the air, so the best rate lies below)."""
        return 1 / (n * Airtime(WifiParams()).frame_airtime(self.frame_bytes))

    @property
    def searches(self) -> list[tuple[str, int]]:
        """(baseline, N) of every fine search, none for the grid."""
        return [(s, n) for n in self.ns for s in BASELINES] if self.search == "fine" else []

    @property
    def all_rates(self) -> tuple[float, ...]:
        return tuple(sorted({*self.rates, self.fixed_rate}))

    def plan(self) -> list[WifiScenario]:
        """Every run of the sweep, in a fixed order."""
        runs = []
        for n in self.ns:
            for batch in range(self.batches):
                runs.append(self.scenario(n, batch, "wiswarm", self.fixed_rate))
                for system in BASELINES:
                    runs.extend(self.scenario(n, batch, system, r) for r in self.all_rates)
        return runs

    def scenario(self, n: int, batch: int, system: str, rate: float) -> WifiScenario:
        return WifiScenario(
            n=n, system=system, rate=rate, frame_bytes=self.frame_bytes,
            duration=self.duration, seed=self.seed + batch,
        )


def search_runs(config: SweepConfig, search: tuple[str, int]) -> list[WifiResult]:
    """Every run of the fine search of ``search`` (baseline, N), in order: each rate it
    tries in every batch, its cost their mean AoI (``rate_cost``)."""
    system, n = search
    runs: list[WifiResult] = []

    def cost(rate: float) -> float:
        batch = [run_wifi(config.scenario(n, b, system, rate)) for b in range(config.batches)]
        runs.extend(batch)
        return rate_cost(batch)

    fine_search(cost, config.share_fps(n))
    return runs


def rate_cost(group: Sequence[WifiResult]) -> float:
    """What a search minimises: the mean AoI over the batches (a point's mean)."""
    return statistics.fmean(r.mean("mean_aoi_s") for r in group)


@contextlib.contextmanager
def _mapper(jobs: int) -> Iterator[Callable[[Callable[[T], R], Iterable[T]], Iterator[R]]]:
    """``map`` on ``jobs`` processes (in order), or here for one."""
    if jobs <= 1:
        yield map
        return
    with multiprocessing.get_context("spawn").Pool(jobs) as pool:
        yield pool.imap


def run_sweep(
    config: SweepConfig, jobs: int, progress: Callable[[int, int], None]
) -> list[WifiResult]:
    """Run the plan, then the fine searches (each search's runs in order, the searches
    side by side), on ``jobs`` processes; ``progress(done, total)`` after each run or
    search (the total estimated: a search's runs are known when it ends)."""
    plan = config.plan()
    total = len(plan) + len(config.searches) * FINE_SEARCH_RUNS * config.batches
    results: list[WifiResult] = []
    progress(0, total)
    with _mapper(jobs) as mapped:
        for result in mapped(run_wifi, plan):
            results.append(result)
            progress(len(results), max(total, len(results)))
        for runs in mapped(partial(search_runs, config), config.searches):
            results += runs
            progress(len(results), max(total, len(results)))
    return results


@dataclass(frozen=True)
class Point:
    """Mean and standard deviation over batches of one system at one N."""

    label: str
    n: int
    rate: float | None
    mean: dict[str, float]
    std: dict[str, float]


def point_of(label: str, group: Sequence[WifiResult]) -> Point:
    values = {m: [r.mean(m) for r in group] for m in METRICS}
    return Point(
        label=label, n=group[0].n, rate=group[0].rate,
        mean={m: statistics.fmean(v) for m, v in values.items()},
        std={m: statistics.stdev(v) if len(v) > 1 else 0.0 for m, v in values.items()},
    )


def searched(config: SweepConfig, results: Sequence[WifiResult], system: str, n: int
             ) -> list[tuple[float, float]]:
    """(rate, mean AoI over the batches) of every rate the search of ``system`` at N
    tried, in order: the grid's rates with ``grid``, else the rates off the grid (the
    fine search's are the share times powers of 1.25 and golden sections: never a
    whole frame rate exactly)."""
    def of_search(rate: float) -> bool:
        return rate in config.rates if config.search == "grid" else rate not in config.all_rates

    groups: dict[float, list[WifiResult]] = {}
    for r in results:
        if (r.system, r.n) == (system, n) and r.rate is not None and of_search(r.rate):
            groups.setdefault(r.rate, []).append(r)
    return [(rate, rate_cost(group)) for rate, group in groups.items()]


def summarise(config: SweepConfig, results: Sequence[WifiResult]) -> list[Point]:
    """Points for every (system, rate, N), plus ``<baseline>-opt`` at each N's best rate
    of its search (``searched``).

    Labels: ``wiswarm``, ``udp@R``/``tcp@R`` for every rate run, ``udp-opt``/``tcp-opt``.
    """
    groups: dict[tuple[str, float | None, int], list[WifiResult]] = {}
    for r in results:
        groups.setdefault((r.system, r.rate, r.n), []).append(r)
    points = []
    for (system, rate, _), group in sorted(groups.items(), key=lambda kv: str(kv[0])):
        points.append(point_of(system if rate is None else f"{system}@{rate:g}", group))
    for n in config.ns:
        for system in BASELINES:
            tried = dict(searched(config, results, system, n))
            best = min((p for p in points if p.n == n and p.label.startswith(f"{system}@")
                        and p.rate in tried), key=lambda p: p.mean["mean_aoi_s"])
            points.append(Point(f"{system}-opt", n, best.rate, best.mean, best.std))
    return points
