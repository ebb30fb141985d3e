"""The paper's stationary study (Section IV-A) on real processes over the emulated channel.

For every N: WiSwarm, each baseline at the fixed rate (50 fps), and each baseline at its
best rate, found by a search, not by running a whole grid: a baseline's mean AoI against
its rate falls while the channel keeps up (fresher frames) and climbs once the offered
load exceeds the channel's share of each follower (queues build), so it is unimodal.
The search (``search``) is ``fine`` by default: ``rate_search.fine_search`` from that
share (link rate / (N x frame bits)), until the best rate's tried neighbours are within
5 % of it (about seven runs). A grid of whole frames per second misses the best, which
lies just below the cliff: at N = 14 the share is 3.4 fps on 20 Mbit/s, 2.9 fps on the
WiFi medium, and the paper's grid jumps from 3 to 5 fps. ``grid`` is the paper's way
(``best_of_grid``), kept to reproduce it: from the grid rate just below the share,
walking to the better neighbour until a rate is worse (two to four runs).

With ``medium`` set, every run goes over ns-3's WiFi medium instead, a station per
follower (``wifi``), built once per worker with as many stations as the largest N.

Runs go to ``parallel`` workers at once, every run on a channel built for it alone (the
channels are independent bottlenecks: the shaping is the kernel's, and at 20 Mbit/s per
channel the CPU is not what limits a run). Fresh namespaces, not one channel per worker:
runs that share a namespace share its kernel state, and a UDP run at 50 fps leaves the
reassembly memory full of incomplete datagrams for 30 s, which makes the next run's UDP
deliver nothing (``reassembly.py``). The WiFi medium is the exception: its scenario is
built and started per worker, not per run (a run's start counts the leader side's
held fragments in its events). A run's measurements are kept as they complete, so a
study cut short by Ctrl-C reports what it measured.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from wiswarm_zenoh.experiments.rate_search import fine_search
from wiswarm_zenoh.experiments.sweep import FINE_SEARCH_RUNS, PAPER_NS, PAPER_RATES, check_study
from wiswarm_zenoh.programs.frames import FRAME_BYTES
from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.run import (
    ADAPTIVE,
    SYSTEMS,
    WISWARM_SAMPLE_RATE,
    RunOutcome,
    RunSpec,
    measure,
)
from wiswarm_zenoh.testbed.spec import ChannelSpec
from wiswarm_zenoh.testbed.wifi import WifiMedium
from wiswarm_zenoh.testbed.wifi_spec import WifiSpec

log = logging.getLogger(__name__)

BASELINES = tuple(s for s in SYSTEMS if s != "wiswarm")  # newest only too (ADAPTIVE)
FRAME_OVERHEAD = 1.04  # headers per byte of frame on the wire (Zenoh, TCP/IP, Ethernet)


def share_fps(rate_bps: float, n: int, frame_bytes: int) -> float:
    """Frames per second per follower that a link of ``rate_bps`` carries for N."""
    return rate_bps / (n * frame_bytes * 8 * FRAME_OVERHEAD)


SEARCH_RUNS = {"fine": FINE_SEARCH_RUNS, "grid": 3}  # a typical search's runs
JOIN_PERIOD = 0.2  # seconds between checks that the workers ended


@dataclass(frozen=True)
class StudyConfig:
    """What to measure; validated on construction (ValueError names the field)."""

    ns: tuple[int, ...] = PAPER_NS
    baselines: tuple[str, ...] = BASELINES
    rates: tuple[float, ...] = PAPER_RATES  # the grid of search "grid"
    fixed_rate: float = 50.0
    search: str = "fine"  # how a baseline's best rate is found: fine or grid
    batches: int = 1
    duration: float = 30.0
    warmup: float = 5.0
    frame_bytes: int = FRAME_BYTES
    channel: ChannelSpec = field(default_factory=ChannelSpec)
    parallel: int = 1
    medium: WifiSpec | None = None  # None: the tbf channel

    def __post_init__(self) -> None:
        check_study(self.ns, self.rates, self.batches, self.search)
        unknown = sorted(set(self.baselines) - set(BASELINES))
        if unknown:
            raise ValueError(f"unknown baselines {unknown}: choose from {', '.join(BASELINES)}")
        if self.parallel < 1:
            raise ValueError(f"parallel must be >= 1, got {self.parallel}")
        self.spec("wiswarm", self.ns[0], None, 0)  # the run's own checks

    def spec(self, system: str, n: int, rate: float | None, batch: int) -> RunSpec:
        return RunSpec(system, n, WISWARM_SAMPLE_RATE if rate is None else rate,
                       duration=self.duration, warmup=self.warmup,
                       frame_bytes=self.frame_bytes, batch=batch)

    def share_fps(self, n: int) -> float:
        """Frames per second per follower that the uplink carries when N share it."""
        rate = self.channel.rate_bps if self.medium is None else self.medium.capacity_bps
        return share_fps(rate, n, self.frame_bytes)

    def build_medium(self) -> WifiMedium:
        """A worker's WiFi medium, with a station for the largest N (the tbf channel is
        built per run instead: ``measure_fresh``)."""
        if self.medium is None:
            raise ValueError("no WiFi medium: the tbf channel is built per run")
        return WifiMedium(replace(self.medium, stations=max(self.ns)))

    @property
    def estimated_runs(self) -> int:
        searches = sum(system not in ADAPTIVE for system in self.baselines)
        per_n = 1 + len(self.baselines) + searches * SEARCH_RUNS[self.search]
        return per_n * len(self.ns) * self.batches


Measure = Callable[[RunSpec], RunOutcome]


@dataclass
class Job:
    """Work for one worker: a single run at ``rate`` (None: the camera's, as WiSwarm and
    newest only run), or the best-rate search of one baseline."""

    system: str
    n: int
    batch: int
    search: bool = False
    rate: float | None = None


def best_of_grid(grid: Sequence[float], share: float, cost: Callable[[float], float]
                 ) -> float:
    """The rate of ``grid`` with the lowest ``cost`` on a unimodal curve: from the grid
    rate just below ``share`` (where queues start to build), towards the better
    neighbour (the one above tried first) until a rate is worse than the one before it.
    Each rate is measured once, and a grid of one rate is measured too (the caller knows
    the best: its run is kept)."""
    rates = sorted(grid)
    start = max((i for i, r in enumerate(rates) if r <= share), default=0)
    costs: dict[int, float] = {}

    def at(i: int) -> float:
        if i not in costs:
            costs[i] = cost(rates[i])
        return costs[i]

    best, step = start, -1
    at(start)
    if start + 1 < len(rates) and at(start + 1) < at(start):
        best, step = start + 1, 1
    while 0 <= best + step < len(rates) and at(best + step) < at(best):
        best += step
    return rates[best]


def best_rate(config: StudyConfig, job: Job, run: Measure) -> float:
    """The rate with the lowest mean AoI for ``job``'s baseline at N, by the config's
    search from the channel's share (see module)."""
    def cost(rate: float) -> float:
        return run(config.spec(job.system, job.n, rate, job.batch)).result.mean("mean_aoi_s")

    share = config.share_fps(job.n)
    if config.search == "grid":
        return best_of_grid(config.rates, share, cost)
    return fine_search(cost, share)


def searched(config: StudyConfig, results: StudyResults, system: str, n: int, batch: int
             ) -> list[tuple[float, float]]:
    """(rate, mean AoI) of every rate the search of ``system`` at N in ``batch`` ran, in
    order: that baseline's runs there but its fixed-rate one. Read from the runs, so a
    study cut short, or merged N by N (``--live``), has them too."""
    runs = [(o.result.rate, o.result.mean("mean_aoi_s")) for o in results.outcomes
            if (o.result.system, o.result.n, o.result.seed) == (system, n, batch)
            and o.result.rate is not None]
    fixed = next((i for i, (rate, _) in enumerate(runs) if rate == config.fixed_rate), None)
    return [run for i, run in enumerate(runs) if i != fixed]


def plan(config: StudyConfig) -> Iterator[Job]:
    """Every job, N by N: WiSwarm, the baselines at the fixed rate (newest only at the
    camera's: it adapts), then the searches (none for newest only: no rate to find)."""
    for n in config.ns:
        for batch in range(config.batches):
            yield Job("wiswarm", n, batch)
            for system in config.baselines:
                yield Job(system, n, batch,
                          rate=None if system in ADAPTIVE else config.fixed_rate)
            for system in config.baselines:
                if system not in ADAPTIVE:
                    yield Job(system, n, batch, search=True)


@dataclass
class StudyResults:
    """Every run measured so far (thread-safe), and each search's choice."""

    outcomes: list[RunOutcome] = field(default_factory=list)
    interrupted: bool = False
    best: dict[tuple[str, int, int], float] = field(default_factory=dict)  # (system, n, batch)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, outcome: RunOutcome) -> None:
        with self.lock:
            self.outcomes.append(outcome)


def measure_fresh(channel: ChannelSpec, spec: RunSpec, workdir: Path,
                  stop: threading.Event) -> RunOutcome:
    """``spec`` measured on a channel built for it and removed after it: namespaces in
    the state the kernel makes them, nothing left by the run before (see module)."""
    with Channel(channel) as fresh:
        return measure(fresh, spec, workdir, stop)


def run_study(config: StudyConfig, workdir: Path, progress: Callable[[int, int], None],
              stop: threading.Event | None = None) -> StudyResults:
    """Run every job of the plan on ``config.parallel`` channels; returns what was
    measured, also when Ctrl-C or ``stop`` ends it midway (``interrupted``; the runs in
    progress are kept, over the window they measured). Each run's channel is removed
    when the run ends; a worker's WiFi medium when the worker ends."""
    stop = stop or threading.Event()
    results = StudyResults()
    jobs: queue.SimpleQueue[Job] = queue.SimpleQueue()
    for job in plan(config):
        jobs.put(job)
    completed = [0]
    failures: list[BaseException] = []

    def run_on(medium: WifiMedium | None) -> Measure:
        def run(spec: RunSpec) -> RunOutcome:
            if stop.is_set():
                raise _Stopped
            outcome = (measure_fresh(config.channel, spec, workdir, stop) if medium is None
                       else measure(medium, spec, workdir, stop))
            if outcome.result.duration <= 0:  # cut before its window opened: nothing to keep
                raise _Stopped
            results.add(outcome)
            with results.lock:
                completed[0] += 1
                progress(completed[0], max(config.estimated_runs, completed[0]))
            for event in outcome.events:
                log.warning("%s N=%d: %s", spec.label, spec.n, event)
            if not outcome.complete:
                raise _Stopped
            return outcome
        return run

    def worker(done: threading.Event) -> None:
        try:
            with contextlib.ExitStack() as stack:
                run = run_on(None if config.medium is None
                             else stack.enter_context(config.build_medium()))
                while not stop.is_set():
                    try:
                        job = jobs.get_nowait()
                    except queue.Empty:
                        return
                    if job.search:
                        best = best_rate(config, job, run)
                        with results.lock:
                            results.best[(job.system, job.n, job.batch)] = best
                    else:
                        run(config.spec(job.system, job.n, job.rate, job.batch))
        except _Stopped:
            return
        except BaseException as exc:  # reported by the caller, after every worker ended
            failures.append(exc)
            stop.set()
        finally:
            done.set()

    progress(0, config.estimated_runs)
    finished = [threading.Event() for _ in range(config.parallel)]
    workers = [threading.Thread(target=worker, args=(done,), name=f"testbed-{i}")
               for i, done in enumerate(finished)]
    for thread in workers:
        thread.start()
    while True:  # not Thread.join: once interrupted, it may no longer wait (CPython 3.11)
        try:
            for done in finished:
                while not done.wait(JOIN_PERIOD):
                    pass
            break
        except KeyboardInterrupt:  # Ctrl-C: the runs in progress end and are kept
            stop.set()
    results.interrupted = stop.is_set() and not failures
    if failures:
        raise RuntimeError(f"a testbed run failed: {failures[0]}") from failures[0]
    return results


class _Stopped(Exception):
    """The study was told to stop: the worker leaves its job."""
