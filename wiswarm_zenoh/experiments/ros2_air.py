"""ROS 2's own routing over the shared air against WiSwarm (issue 33): N robots, each a
Zenoh router of its own with a 30 Hz camera topic published into it (``ros2_air_nodes``),
the robots' routers connected to the ground's across the testbed's shared channel (tbf)
or ns-3's WiFi medium, and at the ground a ROS 2 subscriber recording every frame's age.
Three ways to get the frames to the ground:

- ``direct`` (a): subscribe to the robots' topics; Zenoh routes every publication over
  the air, as a ROS 2 team's ground station does today;
- ``throttled`` (b): the same, each robot's topic dropped to at most R Hz at the robot
  (zenoh-bridge-ros2dds's ``pub_max_frequencies``), R the best found by the fine search
  (``rate_search``) from the medium's share of each robot;
- ``wiswarm`` (c): a ``wiswarm follower --ros2-topic`` on each robot and ``wiswarm
  leader --ros2`` at the ground; subscribe to the leader's republished topics;
- ``newest`` (d): newest-only push, a ``wiswarm follower --system push --newest-only
  --ros2-topic`` on each robot putting its newest frame where a leader would republish
  it, the moment its last put completed; the robot's router's queues towards the
  ground as small as the follower's (``NEWEST_ZENOH``).

A case is an entry of ``KINDS``: what runs on each robot and at the ground besides the
routers and cameras.

On the tbf channel the robots share its follower side's namespace (their routers on
ports of their own), every byte to the ground crossing the one shaped uplink; on the
WiFi medium each robot is a station of its own. Each run gets a fresh tbf channel; the
WiFi medium is built once, with a station for the largest N. The age is measured over a
window after a warm-up that starts once every robot's first frame reached the ground.
"""

from __future__ import annotations

import contextlib
import csv
import json
import logging
import multiprocessing
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from wiswarm_zenoh.baselines.senders import NEWEST_ZENOH
from wiswarm_zenoh.experiments.cli_processes import Cli, start_cli, stop_cli
from wiswarm_zenoh.experiments.edge_cloud_topology import client_of_local_router
from wiswarm_zenoh.experiments.rate_search import fine_search
from wiswarm_zenoh.experiments.ros2_air_nodes import (
    CAMERA_HZ,
    DOMAIN,
    IMAGE_BYTES,
    ProbeOptions,
    RobotOptions,
    camera_topic,
    robot_name,
    robot_router,
    run_probe,
    run_robot,
    throttled_hz,
)
from wiswarm_zenoh.experiments.testbed_study import share_fps
from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.runners import LeaderOptions, run_leader, run_router
from wiswarm_zenoh.ros2.bridge import Ros2Options, default_namespace
from wiswarm_zenoh.sim.metrics import FollowerMetrics
from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.netns import run_in
from wiswarm_zenoh.testbed.nodes import Placement
from wiswarm_zenoh.testbed.run import Medium, follower_groups, read_record, window_metrics
from wiswarm_zenoh.testbed.spec import ChannelSpec
from wiswarm_zenoh.testbed.tc import run_json
from wiswarm_zenoh.testbed.wifi import TAP, WifiMedium
from wiswarm_zenoh.testbed.wifi_spec import MediumStats, WifiSpec, window_counters

log = logging.getLogger(__name__)



@dataclass(frozen=True)
class Kind:
    """What a case runs besides the robots' routers and cameras: a ``wiswarm follower
    --ros2-topic`` on each robot with these flags added (None: none; the ground then
    subscribes to its republished topic), ``wiswarm leader --ros2`` at the ground, and
    more of each robot's router's config."""

    title: str  # the report's
    follower: tuple[str, ...] | None = None
    leader: bool = False
    router: tuple[str, ...] = ()


KINDS = {"direct": Kind("(a) direct"), "throttled": Kind("(b) throttled"),
         "wiswarm": Kind("(c) WiSwarm", follower=(), leader=True),
         "newest": Kind("(d) newest-only push", follower=("--system", "push", "--newest-only"),
                        router=NEWEST_ZENOH)}
CASES = tuple(KINDS)
SEARCHED = "throttled"  # the case whose rate is searched
MEDIA = ("tbf", "wifi")
SWARM = "air"
SUPERVISE_PERIOD = 0.5


@dataclass(frozen=True)
class AirCase:
    """One run: a case of CASES at N robots; ``max_hz`` is (b)'s throttle."""

    kind: str
    n: int
    max_hz: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in CASES:
            raise ValueError(f"kind must be one of {', '.join(CASES)}, got {self.kind!r}")
        if self.n < 1:
            raise ValueError(f"n must be >= 1, got {self.n}")
        if (self.kind == SEARCHED) != (self.max_hz is not None):
            raise ValueError("max_hz is the throttled case's rate, and only its")

    @property
    def label(self) -> str:
        return f"{self.kind}@{self.max_hz:.3g}" if self.max_hz is not None else self.kind

    @property
    def robots(self) -> list[str]:
        return [robot_name(k) for k in range(1, self.n + 1)]

    @property
    def spec(self) -> Kind:
        return KINDS[self.kind]

    def topic(self, index: int) -> str:
        """What the ground subscribes to for robot ``index``: its own topic, or the one
        republished for it (``<NS>/<follower>/<topic without its leading />``)."""
        if self.spec.follower is None:
            return camera_topic(index)
        return f"{default_namespace(SWARM)}/{follower_id(index)}{camera_topic(index)}"


def follower_id(index: int) -> str:
    return f"d{index}"


@dataclass(frozen=True)
class AirConfig:
    """What to measure; validated on construction (ValueError names the field)."""

    ns: tuple[int, ...] = (4, 8)
    media: tuple[str, ...] = MEDIA
    duration: float = 20.0
    warmup: float = 5.0
    channel: ChannelSpec = field(default_factory=ChannelSpec)
    wifi: WifiSpec = field(default_factory=WifiSpec)

    def __post_init__(self) -> None:
        if not self.ns or min(self.ns) < 1:
            raise ValueError("ns must be a non-empty list of integers >= 1")
        unknown = sorted(set(self.media) - set(MEDIA))
        if not self.media or unknown:
            raise ValueError(f"media must be some of {', '.join(MEDIA)}, got {self.media}")
        if not (self.duration > 0 and self.warmup >= 0):
            raise ValueError("duration must be > 0 and warmup >= 0 seconds")

    def share_fps(self, medium: str, n: int) -> float:
        """Frames per second per robot that the medium carries when N share it."""
        rate = self.channel.rate_bps if medium == "tbf" else self.wifi.capacity_bps
        return share_fps(rate, n, IMAGE_BYTES)


@dataclass(frozen=True)
class CaseResult:
    """What one run measured over its window: each robot's age at the ground, the
    channel's bytes each way, and in (c) the leader's deliveries, their bytes and its
    polls (the window's share of its whole run's polls per delivery); on the WiFi medium
    its counters over the window (``window_counters``)."""

    medium: str
    case: AirCase
    duration: float
    robots: list[FollowerMetrics]
    up_bytes: int
    down_bytes: int
    replies: int = 0
    reply_bytes: int = 0
    polls: float = 0.0
    medium_counters: dict[str, float] = field(default_factory=dict)  # the WiFi medium's
    load: float = 0.0  # the host's load average (1 min) at the run's end

    def mean(self, name: str = "mean_aoi_s") -> float:
        return sum(float(getattr(r, name)) for r in self.robots) / len(self.robots)

    @property
    def frames(self) -> int:
        return sum(r.deliveries for r in self.robots)


def ground_placement(medium: Medium) -> Placement:
    """The ground: the channel's leader side (the WiFi medium's access point)."""
    return Placement(medium.leader_ns, "", medium.leader_addr)


def robot_namespaces(medium: Medium, n: int) -> list[str]:
    """Robot k's namespace at index k - 1: the tbf channel's follower side for all, a
    station each on the WiFi medium."""
    return [ns for _, ns, indices in follower_groups(medium, n) for _ in indices]


def air_bytes(medium: Medium) -> tuple[int, int]:
    """Bytes the shared medium carried so far, to the ground and from it: the tbf
    channel's two qdiscs, or what the access point's tap took from the air and gave it."""
    if isinstance(medium, Channel):
        return medium.uplink().sent_bytes, medium.downlink().sent_bytes
    stats = run_json("ip", "-n", medium.leader_ns, "-s", "-j", "link", "show", "dev",
                     TAP)[0]["stats64"]
    return int(stats["rx"]["bytes"]), int(stats["tx"]["bytes"])


def follower_command(index: int) -> list[str]:
    """Robot ``index``'s ``wiswarm follower`` (the arguments after ``wiswarm``), before
    a case's own flags (``Kind.follower``)."""
    return ["follower", "--swarm", SWARM, "--id", follower_id(index), "--ros2-topic",
            camera_topic(index), "--ros-domain", str(DOMAIN), "-m", "client",
            "-e", robot_router(index), "--no-multicast-scouting"]


@contextlib.contextmanager
def cli_processes(commands: Sequence[tuple[str, list[str]]], logs: Path) -> Iterator[list[Cli]]:
    """``wiswarm <argv>`` in each namespace, stderr to a file in ``logs``; stopped on
    leaving (``cli_processes``)."""
    procs: list[Cli] = []
    try:
        for ns, argv in commands:
            procs.append(start_cli(ns, argv, logs, f"{argv[0]}-{argv[4]}"))
        yield procs
    finally:
        stop_cli(procs)


def _leader_counts(record: Path, t0: float, t1: float) -> tuple[int, int, float]:
    """(c)'s deliveries and their bytes in [t0, t1] from the leader's record, and its
    polls then: the window's deliveries times its whole run's polls per delivery."""
    replies = size = 0
    with record.open(newline="") as rows:
        for row in csv.DictReader(rows):
            if t0 <= float(row["delivered_at"]) <= t1:
                replies += 1
                size += int(row["bytes"])
    stats = record.with_suffix(".json")
    followers = json.loads(stats.read_text())["followers"] if stats.exists() else []
    polls = sum(int(f["polls"]) for f in followers)
    delivered = sum(int(f["deliveries"]) for f in followers)
    return replies, size, replies * polls / delivered if delivered else 0.0


def _start(children: Children, medium: Medium, case: AirCase, leader_record: Path) -> None:
    """The ground's router, the robots, and (c)'s leader."""
    ground = ground_placement(medium)
    children.start("ground-router", run_in, ground.leader_ns, run_router, ground.router())
    for index, ns in enumerate(robot_namespaces(medium, case.n), start=1):
        children.start(f"robot{index}", run_in, ns, run_robot,
                       RobotOptions(index, ground.router_endpoint, case.max_hz,
                                    router_cfg=case.spec.router), wait=False)
    if case.spec.leader:
        children.start("leader", run_in, ground.leader_ns, run_leader, client_of_local_router(),
                       LeaderOptions(SWARM, record=str(leader_record),
                                     stats_file=str(leader_record.with_suffix(".json")),
                                     bridge=Ros2Options(domain=DOMAIN)), wait=False)
    children.wait_ready()


def measure_case(medium: Medium, name: str, case: AirCase, config: AirConfig, workdir: Path
                 ) -> CaseResult:
    """Run ``case`` over ``medium`` (called ``name``: tbf or wifi); RuntimeError if a
    process ends during it, MediumFailed if the WiFi medium falls behind real time."""
    stem = f"{workdir / name}-{case.label}-n{case.n}"
    probe, leader_record = Path(f"{stem}.csv"), Path(f"{stem}-leader.csv")
    robots = robot_namespaces(medium, case.n)
    flags = case.spec.follower
    followers = [] if flags is None else [(ns, follower_command(k) + list(flags))
                                          for k, ns in enumerate(robots, start=1)]
    senders = [*(["leader"] if case.spec.leader else []),
               *(f"robot{k}" for k in range(1, case.n + 1))]
    children = Children(multiprocessing.get_context("spawn"))
    with children:
        _start(children, medium, case, leader_record)
        with cli_processes(followers, workdir) as procs:
            topics = tuple((robot_name(k), case.topic(k)) for k in range(1, case.n + 1))
            children.start("probe", run_in, medium.leader_ns, run_probe,
                           client_of_local_router(), ProbeOptions(topics, str(probe)))
            started = time.time()
            t0, t1 = started + config.warmup, started + config.warmup + config.duration
            watch = _Watch(medium, children, ["ground-router", "probe", *senders], procs)
            first = watch.until(t0)
            last = watch.until(t1)
            children.stop(["probe"])
        children.stop(senders)  # before the router they reach the ground through
    metrics = window_metrics(read_record(probe), case.robots, started, t0, t1, IMAGE_BYTES)
    replies, size, polls = (_leader_counts(leader_record, t0, t1) if case.spec.leader
                            else (0, 0, 0.0))
    counters = ({} if first.medium is None or last.medium is None
                else window_counters(first.medium, last.medium, t1 - t0))
    return CaseResult(name, case, t1 - t0, metrics, last.up - first.up,
                      last.down - first.down, replies, size, polls, counters,
                      os.getloadavg()[0])


@dataclass(frozen=True)
class _Snapshot:
    up: int
    down: int
    medium: MediumStats | None  # the WiFi medium's counters


class _Watch:
    """Checks every process (and the WiFi medium) while a run goes on."""

    def __init__(self, medium: Medium, children: Children, names: list[str],
                 procs: list[Cli]) -> None:
        self._medium, self._children, self._names, self._procs = medium, children, names, procs

    def until(self, moment: float) -> _Snapshot:
        """Watch until ``moment``; the medium's counters then. RuntimeError names a
        process that ended meanwhile."""
        wifi = self._medium if isinstance(self._medium, WifiMedium) else None
        while (left := moment - time.time()) > 0:
            time.sleep(min(SUPERVISE_PERIOD, left))
            dead = [name for name in self._names if not self._children.alive(name)]
            dead += [what for what, proc in self._procs if proc.poll() is not None]
            if dead:
                raise RuntimeError(f"a process ended during the run: {dead[0]}")
            if wifi is not None:
                wifi.check()
        return _Snapshot(*air_bytes(self._medium), None if wifi is None else wifi.stats())


@dataclass
class AirResults:
    """Every run, and per (medium, N) (b)'s best rate and the share its search started
    from; the rates it tried are its runs (``tried``)."""

    runs: list[CaseResult] = field(default_factory=list)
    best: dict[tuple[str, int], float] = field(default_factory=dict)
    share: dict[tuple[str, int], float] = field(default_factory=dict)

    def tried(self, medium: str, n: int) -> list[tuple[float, float]]:
        """(rate, mean AoI) of every throttle (b)'s search ran at N, in order."""
        return [(r.case.max_hz, r.mean()) for r in self.runs
                if (r.medium, r.case.n) == (medium, n) and r.case.max_hz is not None]

    def find(self, medium: str, n: int, kind: str, max_hz: float | None = None
             ) -> CaseResult | None:
        return next((r for r in self.runs if (r.medium, r.case.n, r.case.kind, r.case.max_hz)
                     == (medium, n, kind, max_hz)), None)


MediumFactory = Callable[[], contextlib.AbstractContextManager[Medium]]


@contextlib.contextmanager
def _media(config: AirConfig, name: str) -> Iterator[MediumFactory]:
    """A medium for each run: a fresh tbf channel, or the one WiFi medium."""
    if name == "tbf":
        yield lambda: Channel(config.channel)
        return
    with WifiMedium(replace(config.wifi, stations=max(config.ns))) as wifi:
        yield lambda: contextlib.nullcontext(wifi)


def run_air(config: AirConfig, workdir: Path,
            progress: Callable[[CaseResult], None] | None = None) -> AirResults:
    """Every medium and N: each case but (b), then (b)'s fine search for its best rate
    from the medium's share, up to the camera's rate (there the throttle passes all).
    A throttle of R Hz passes every k-th frame of the camera (``throttled_hz``): the
    search's rates are run at what the throttle gives, each once."""
    results = AirResults()
    for name in config.media:
        with _media(config, name) as medium_for:
            def measure(case: AirCase, name: str = name,
                        medium_for: MediumFactory = medium_for) -> CaseResult:
                with medium_for() as medium:
                    result = measure_case(medium, name, case, config, workdir)
                results.runs.append(result)
                if progress is not None:
                    progress(result)
                return result

            for n in config.ns:
                for kind in CASES:
                    if kind != SEARCHED:
                        measure(AirCase(kind, n))

                def cost(rate: float, n: int = n, name: str = name) -> float:
                    hz = throttled_hz(rate)
                    run = results.find(name, n, SEARCHED, hz)
                    return (run or measure(AirCase(SEARCHED, n, hz))).mean()

                share = results.share[(name, n)] = config.share_fps(name, n)
                results.best[(name, n)] = throttled_hz(fine_search(cost, share, high=CAMERA_HZ))
    return results
