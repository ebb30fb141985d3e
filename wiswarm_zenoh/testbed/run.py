"""One measured run over the emulated channel: a system, N followers, a window.

The leader side (router + polling leader or baseline receiver) starts in the channel's
leader namespace, the N followers in one host process in the follower namespace (each
with a session or socket of its own: the frames still cross the channel; one process
spares the CPU that N would cost). On the WiFi medium each follower is a station of its
own, so each runs in its station's namespace, a process per station. After a warm-up,
AoI is measured over the window from the receiver's record of every delivery, with the
generation time each frame carries (ground truth: every process reads the same host
clock), identically for every system. The run is supervised: a process that dies is
logged with the time and its exit code and started again, one that ends by an error when
the run stops is noted too, and a rate changed on the channel (``wiswarm testbed set``)
is noted when seen; the WiFi medium falling behind real time fails it.
"""

from __future__ import annotations

import csv
import functools
import json
import logging
import multiprocessing
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from wiswarm_zenoh.baselines import (
    BaselineFollowerOptions,
    ReceiverOptions,
    run_baseline_followers,
    run_receiver,
)
from wiswarm_zenoh.core import AoITracker, LeaderConfig
from wiswarm_zenoh.core.config import InFlight
from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.frames import FRAME_BYTES
from wiswarm_zenoh.programs.runners import (
    FollowerOptions,
    LeaderOptions,
    run_followers,
    run_leader,
    run_router,
)
from wiswarm_zenoh.sim.metrics import FollowerMetrics, WifiResult
from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.channel_watch import ChannelSampler, LinkWatch, MediumWatch
from wiswarm_zenoh.testbed.netns import run_in
from wiswarm_zenoh.testbed.nodes import Placement
from wiswarm_zenoh.testbed.reassembly import reassembly
from wiswarm_zenoh.testbed.wifi import WifiMedium

log = logging.getLogger(__name__)

SYSTEMS = ("wiswarm", "push-block", "push-drop", "udp", "tcp", "push-newest", "tcp-newest")
# Newest only (``baselines.newest``): no rate to choose, it adapts; run at the camera's.
ADAPTIVE = ("push-newest", "tcp-newest")
WISWARM_SAMPLE_RATE = 100.0  # the paper: cameras at 100 fps into a LIFO of one
SWARM = "testbed"
SUPERVISE_PERIOD = 0.5  # seconds between checks of the processes


@dataclass(frozen=True)
class RunSpec:
    """One run; validated on construction (ValueError names the field)."""

    system: str
    n: int
    rate: float = WISWARM_SAMPLE_RATE  # camera frames/s (WiSwarm samples, baselines push)
    duration: float = 30.0
    warmup: float = 5.0
    frame_bytes: int = FRAME_BYTES
    batch: int = 0
    in_flight: InFlight = 1  # WiSwarm's polls out at once (``--in-flight``)
    slow: int = 0  # WiSwarm: the last ``slow`` followers' cameras run at ``slow_rate``
    slow_rate: float = 5.0
    pace_sources: bool = True  # False: the paper's index (every source taken as fresh)

    def __post_init__(self) -> None:
        if self.system not in SYSTEMS:
            raise ValueError(f"system must be one of {', '.join(SYSTEMS)}, got {self.system!r}")
        if self.n < 1:
            raise ValueError(f"n must be >= 1, got {self.n}")
        for name in ("rate", "duration"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not self.warmup >= 0:
            raise ValueError(f"warmup must be >= 0, got {self.warmup}")
        if not 0 <= self.slow <= self.n:
            raise ValueError(f"slow must be in [0, n], got {self.slow}")

    @property
    def label(self) -> str:
        if self.system != "wiswarm":
            return f"{self.system}@{self.rate:g}"
        variant = [f"k{self.in_flight}" if self.in_flight != 1 else "",
                   f"slow{self.slow}@{self.slow_rate:g}" if self.slow else "",
                   "" if self.pace_sources else "papers-index"]
        return "-".join(["wiswarm", *filter(None, variant)])

    def leader_config(self) -> LeaderConfig:
        return LeaderConfig(in_flight=self.in_flight, pace_sources=self.pace_sources)

    def camera_rate(self, i: int) -> float:
        """Follower ``i``'s camera rate (frames/s)."""
        return self.slow_rate if i >= self.n - self.slow else self.rate

    @property
    def followers(self) -> list[str]:
        return [f"uav{i}" for i in range(self.n)]


@dataclass
class RunOutcome:
    """What a run measured, and what happened during it (time since the run's start).
    The channel's counters cover the window: its throughput each way, tail drops, the
    uplink queue's mean backlog (what explains a baseline's age), and the leader side's
    IP reassembly (``reasm_*``: fragments, datagrams rebuilt, failures; UDP's frames)."""

    result: WifiResult
    events: list[str] = field(default_factory=list)
    complete: bool = True  # False: cut short (Ctrl-C), measured over a shorter window
    failed: int = 0  # processes that ended during the run or not cleanly at its end


def window_metrics(rows: dict[str, list[tuple[float, float]]], followers: list[str],
                   started: float, t0: float, t1: float, frame_bytes: int
                   ) -> list[FollowerMetrics]:
    """Per follower, AoI over [t0, t1] from its deliveries (delivered_at, generated_at):
    the window opens with the age the last delivery before it left (or the time since
    the run started, if none came)."""
    metrics = []
    for follower in followers:
        deliveries = sorted(rows.get(follower, []))
        before = [generated for delivered, generated in deliveries if delivered < t0]
        freshest = max(before, default=started)
        tracker = AoITracker(t0, initial_age=max(0.0, t0 - freshest))
        for delivered, generated in deliveries:
            if t0 <= delivered <= t1:
                tracker.deliver(generated, delivered)
        metrics.append(FollowerMetrics.from_tracker(follower, tracker, t1, frame_bytes))
    return metrics


def read_record(path: Path) -> dict[str, list[tuple[float, float]]]:
    """A DeliveryRecord CSV as (delivered_at, generated_at) per follower."""
    rows: dict[str, list[tuple[float, float]]] = defaultdict(list)
    if not path.exists():
        return rows
    with path.open(newline="") as src:
        for row in csv.DictReader(src):
            rows[row["follower"]].append((float(row["delivered_at"]),
                                          float(row["generated_at"])))
    return rows


def stats_file(record: Path) -> Path:
    """Where a WiSwarm run's leader leaves its followers' last stats."""
    return record.with_suffix(".stats.json")


def poll_counters(record: Path) -> dict[str, float]:
    """A WiSwarm run's polls, those that found nothing new (neither a delivery nor a
    timeout: every frame here fits one reply), and the polls its leader kept out at the
    end, from its leader's last stats."""
    path = stats_file(record)
    if not path.exists():
        return {}
    last = json.loads(path.read_text())
    stats = last["followers"]
    polls = sum(s["polls"] for s in stats)
    empty = sum(s["polls"] - s["deliveries"] - s["timeouts"] - s["errors"] for s in stats)
    return {"polls": float(polls), "empty_polls": float(max(empty, 0)),
            "in_flight": float(last["leader"]["in_flight"])}


Medium = Channel | WifiMedium
Group = tuple[str, str, list[int]]  # child name, namespace, follower indices


def follower_groups(medium: Medium, n: int) -> list[Group]:
    """Where the followers run: all in the follower namespace of a tbf channel, each in
    its own station's namespace on the WiFi medium (ValueError if N exceeds them)."""
    if isinstance(medium, Channel):
        return [("followers", medium.follower_ns, list(range(n)))]
    stations = medium.station_namespaces
    if n > len(stations):
        raise ValueError(f"{n} followers need {n} stations; the WiFi medium has "
                         f"{len(stations)}")
    return [(f"followers{i}", ns, [i]) for i, ns in enumerate(stations[:n])]


def _start_nodes(children: Children, place: Placement, spec: RunSpec, record: Path,
                 groups: list[Group]) -> None:
    """Router and receiver on the leader side, then the followers across the channel."""
    children.start("router", run_in, place.leader_ns, run_router, place.router())
    followers = spec.followers
    if spec.system == "wiswarm":
        children.start("leader", run_in, place.leader_ns, run_leader, place.leader(),
                       LeaderOptions(SWARM, spec.leader_config(), record=str(record),
                                     record_capture_stamps=True,
                                     stats_file=str(stats_file(record))))
        options = [FollowerOptions(SWARM, f, frame_bytes=spec.frame_bytes,
                                   frame_rate=spec.camera_rate(i))
                   for i, f in enumerate(followers)]
        for name, ns, indices in groups:
            children.start(name, run_in, ns, run_followers, place.follower(),
                           [options[i] for i in indices], wait=False)
        children.wait_ready()
        return
    kind, _, variant = spec.system.partition("-")
    newest = variant == "newest"
    children.start("leader", run_in, place.leader_ns, run_receiver, place.leader(),
                   ReceiverOptions(SWARM, kind, bind=place.socket_receiver, record=str(record)))
    for name, ns, indices in groups:
        children.start(name, run_in, ns, run_baseline_followers, place.follower(),
                       BaselineFollowerOptions(
                           SWARM, tuple(followers[i] for i in indices), kind, spec.rate,
                           "block" if newest or not variant else variant, spec.frame_bytes,
                           receiver=place.socket_receiver, newest_only=newest), wait=False)
    children.wait_ready()


def ending(name: str, code: int | None, early: bool = False) -> str:
    """How a process ended, for a run's events: one that ended during the run (``early``),
    by an error or by a signal failed; ``None``: it never ended."""
    if code is None:
        return f"{name} process did not end"
    how = f"killed by signal {-code}" if code < 0 else f"exit code {code}"
    if early:
        return f"{name} process failed: it ended during the run ({how})"
    return f"{name} process failed: {how}"


def failed_line(failed: int, where: str) -> str:
    """A report's opening warning when processes failed (``where``: runs, setups), so
    that figures from a broken run are not read as the system's; empty otherwise."""
    if not failed:
        return ""
    return (f"**{failed} process failure(s)**: see what happened during the runs; the "
            f"{where} they occurred in measured a system with a process missing.\n\n")


def measure(channel: Medium, spec: RunSpec, workdir: Path,
            stop: threading.Event | None = None,
            on_tick: Callable[[float], None] | None = None) -> RunOutcome:
    """Run ``spec`` over ``channel`` (a tbf channel or the WiFi medium); ``stop`` ends
    the window early (the run is then reported over what it measured); ``on_tick(fraction
    done)`` as it goes. On the WiFi medium, MediumFailed if real time was not held.
    ``workdir`` is made if missing: the records are written there by the children."""
    stop = stop or threading.Event()
    workdir.mkdir(parents=True, exist_ok=True)
    groups = follower_groups(channel, spec.n)
    place = Placement(channel.leader_ns, groups[0][1], channel.leader_addr)
    record = workdir / f"{spec.label}-n{spec.n}-b{spec.batch}.csv"
    events: list[str] = []
    reasm0 = reassembly(channel.leader_ns)
    if reasm0.held:  # a namespace used before: the fragments of the run before are there
        events.append(f"t=0.0s: the leader side held {reasm0.held} incomplete datagrams "
                      f"({reasm0.held_bytes} B) at the start: UDP may lose frames to them")
        log.warning("%s", events[-1])
    names = ("router", "leader", *(group[0] for group in groups))
    failed = 0
    children = Children(multiprocessing.get_context("spawn"))
    with children:
        _start_nodes(children, place, spec, record, groups)
        started = time.time()
        t0 = started + spec.warmup
        t1 = t0 + spec.duration
        watch: LinkWatch | MediumWatch = (
            LinkWatch(channel, started, events) if isinstance(channel, Channel)
            else MediumWatch(channel))
        sampler = ChannelSampler(watch, functools.partial(reassembly, channel.leader_ns), t0)
        try:
            while (now := time.time()) < t1 and not stop.wait(min(SUPERVISE_PERIOD, t1 - now)):
                sampler.check()
                for name in names:
                    if not children.alive(name):
                        failed += 1
                        events.append(f"t={time.time() - started:.1f}s: "
                                      f"{ending(name, children.exit_code(name), early=True)}; "
                                      "started again")
                        children.restart(name)
                if on_tick is not None:
                    on_tick(min(1.0, (time.time() - started) / (t1 - started)))
            end = min(time.time(), t1)
        finally:
            sampler.stop()
        sampler.check()
        reasm0 = sampler.reasm0 or reasm0
        watch.sample()
        reasm1 = reassembly(channel.leader_ns)
        children.stop([group[0] for group in groups])  # the senders before their receiver
        children.stop(["leader"])  # and it before its router: it would see the router go
    stopped = time.time() - started
    stopping = [f"t={stopped:.1f}s, stopping: {ending(name, code)}" for name in names
                if (code := children.exit_code(name)) != 0]
    events += stopping
    complete = end >= t1
    span = max(0.0, end - t0)
    metrics = window_metrics(read_record(record), spec.followers, started, t0,
                             max(end, t0), spec.frame_bytes)
    counters = {**watch.counters(span), **reasm1.since(reasm0), **poll_counters(record)}
    result = WifiResult(system=spec.system, n=spec.n,
                        rate=None if spec.system == "wiswarm" else spec.rate,
                        frame_bytes=spec.frame_bytes, duration=span, seed=spec.batch,
                        followers=metrics, channel=counters)
    return RunOutcome(result, events, complete, failed + len(stopping))
