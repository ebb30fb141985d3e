"""The paper's stationary study (Section IV-A) over the ``wifi`` channel.

For every N: WiSwarm, and WiFi-UDP / WiFi-TCP pushing at every rate of the grid, each
in ``batches`` independent batches. A batch uses the same seed for every system and N,
so all systems see the same links. The rate-optimised baselines take, for each N, the
grid rate with the lowest mean AoI over the batches (the paper picked by tracking
error, which the simulator does not model); the fixed-rate ones take ``fixed_rate``.
"""

from __future__ import annotations

import multiprocessing
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from wiswarm_zenoh.sim.metrics import WifiResult
from wiswarm_zenoh.sim.scenario import PAPER_FRAME_BYTES, WifiScenario, run_wifi

PAPER_RATES = (1.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 25.0, 50.0, 100.0)
PAPER_NS = (2, 4, 6, 8, 10, 12, 14)
BASELINES = ("udp", "tcp")
METRICS = ("mean_aoi_s", "p95_aoi_s", "peak_aoi_s", "throughput_fps", "throughput_mbps")


def check_study(ns: tuple[int, ...], rates: tuple[float, ...], batches: int) -> None:
    """What every study of N and rate needs (ValueError names the field)."""
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

    def __post_init__(self) -> None:
        check_study(self.ns, self.rates, self.batches)
        self.plan()  # every scenario validates itself

    @property
    def all_rates(self) -> tuple[float, ...]:
        return tuple(sorted({*self.rates, self.fixed_rate}))

    def plan(self) -> list[WifiScenario]:
        """Every run of the sweep, in a fixed order."""
        runs = []
        for n in self.ns:
            for batch in range(self.batches):
                runs.append(self._scenario(n, batch, "wiswarm", self.fixed_rate))
                for system in BASELINES:
                    runs.extend(self._scenario(n, batch, system, r) for r in self.all_rates)
        return runs

    def _scenario(self, n: int, batch: int, system: str, rate: float) -> WifiScenario:
        return WifiScenario(
            n=n, system=system, rate=rate, frame_bytes=self.frame_bytes,
            duration=self.duration, seed=self.seed + batch,
        )


def run_sweep(
    config: SweepConfig, jobs: int, progress: Callable[[int, int], None]
) -> list[WifiResult]:
    """Run the plan on ``jobs`` processes; ``progress(done, total)`` after each run."""
    plan = config.plan()
    results: list[WifiResult] = []
    progress(0, len(plan))
    if jobs <= 1:
        for scenario in plan:
            results.append(run_wifi(scenario))
            progress(len(results), len(plan))
        return results
    with multiprocessing.get_context("spawn").Pool(jobs) as pool:
        for result in pool.imap(run_wifi, plan):
            results.append(result)
            progress(len(results), len(plan))
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


def summarise(config: SweepConfig, results: Sequence[WifiResult]) -> list[Point]:
    """Points for every (system, rate, N), plus ``<baseline>-opt`` at each N's best rate.

    Labels: ``wiswarm``, ``udp@R``/``tcp@R`` for every grid rate, ``udp-opt``/``tcp-opt``.
    """
    groups: dict[tuple[str, float | None, int], list[WifiResult]] = {}
    for r in results:
        groups.setdefault((r.system, r.rate, r.n), []).append(r)
    points = []
    for (system, rate, _), group in sorted(groups.items(), key=lambda kv: str(kv[0])):
        points.append(point_of(system if rate is None else f"{system}@{rate:g}", group))
    for n in config.ns:
        for system in BASELINES:
            candidates = [p for p in points if p.n == n and p.label.startswith(f"{system}@")
                          and p.rate in config.rates]
            best = min(candidates, key=lambda p: p.mean["mean_aoi_s"])
            points.append(Point(f"{system}-opt", n, best.rate, best.mean, best.std))
    return points
