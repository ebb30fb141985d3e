"""The mission benchmark: a swarm that changes under the network, over the testbed's
tbf channel or ns-3's WiFi medium, with every way a ROS 2 team gets its robots' camera
topics to the ground (``SYSTEMS``).

The robots are the ROS 2 air benchmark's (``ros2_air_nodes``): each a Zenoh router of
its own with a 30 Hz, 50 kB camera topic in rmw_zenoh's format, and the ground's ROS 2
subscriber records every frame's age. A mission (``mission_scenario``) says, phase by
phase, who flies, whose link is degraded and whose weight moved; here those happen at
their times on a running swarm: robots (and their followers) started and stopped, a
robot's link capped (its flows on the tbf uplink, or its station's PHY rate on the WiFi
medium), a weight put on the leader's weight key. Nothing is restarted or re-tuned
between phases but the oracle throttle, which is told each phase's best rate.

The fixed rates are tuned by short static runs of a phase's conditions, the rate found
by the fine search (``rate_search``); each tuned rate is kept in the output directory's
``tuned.json`` and reused by the next run there.
"""

from __future__ import annotations

import contextlib
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
from wiswarm_zenoh.experiments.mission_nodes import OperatorOptions, run_operator
from wiswarm_zenoh.experiments.mission_scenario import Mission, Phase
from wiswarm_zenoh.experiments.ros2_air import (
    MEDIA,
    SWARM,
    AirCase,
    air_bytes,
    follower_command,
    follower_id,
    ground_placement,
    robot_namespaces,
)
from wiswarm_zenoh.experiments.ros2_air_nodes import (
    IMAGE_BYTES,
    ProbeOptions,
    RobotOptions,
    robot_name,
    run_probe,
    run_robot,
)
from wiswarm_zenoh.experiments.testbed_study import share_fps
from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.runners import LeaderOptions, run_leader, run_router
from wiswarm_zenoh.ros2.bridge import Ros2Options
from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.netns import run_in
from wiswarm_zenoh.testbed.run import Medium, read_record
from wiswarm_zenoh.testbed.spec import ChannelSpec
from wiswarm_zenoh.testbed.wifi import WifiMedium
from wiswarm_zenoh.testbed.wifi_spec import ERP_MBPS, HT_20MHZ_MBPS, WifiSpec
from wiswarm_zenoh.transport.keys import SwarmKeys

log = logging.getLogger(__name__)

SYSTEMS = ("direct", "fixed-first", "fixed-largest", "oracle", "newest", "wiswarm")
LABELS = {
    "direct": "(a) rmw_zenoh's routing",
    "fixed-first": "(b1) throttle tuned for phase 1",
    "fixed-largest": "(b2) throttle tuned for the most robots",
    "oracle": "(b*) throttle re-tuned every phase (oracle)",
    "newest": "(d) newest-only push",
    "wiswarm": "(c) WiSwarm",
}
THROTTLED = ("fixed-first", "fixed-largest", "oracle")
REALIZABLE = ("direct", "fixed-first", "fixed-largest", "newest")
# (d): wiswarm follower's flags, and the robot's router's queues towards the ground as
# small as the follower's own (one batch, a 16 KiB send buffer), as a careful engineer
# sets them for newest-only: with the defaults, the router's TCP buffer alone holds
# seconds of frames before a put blocks
NEWEST_ONLY = ("--system", "push", "--newest-only")
SUPERVISE_PERIOD = 0.25
CONNECT_WAIT = 10.0  # seconds for a robot that just took off to reach the ground
WEIGHT_REPEATS = (0.0, 2.0, 5.0)  # a weight put again this long after its phase starts:
# a robot that joins in the phase is polled once its token reached the leader


@dataclass(frozen=True)
class MissionConfig:
    """What to run; validated on construction (ValueError names the field)."""

    mission: Mission
    media: tuple[str, ...] = MEDIA
    systems: tuple[str, ...] = SYSTEMS
    warmup: float = 10.0  # from the first process started to the mission's clock
    tune_seconds: float = 15.0  # each tuning run's window
    tune_warmup: float = 8.0
    channel: ChannelSpec = field(default_factory=ChannelSpec)
    wifi: WifiSpec = field(default_factory=WifiSpec)

    def __post_init__(self) -> None:
        unknown = sorted(set(self.systems) - set(SYSTEMS))
        if not self.systems or unknown:
            raise ValueError(f"systems must be some of {', '.join(SYSTEMS)}, got "
                             f"{','.join(self.systems)}")
        bad_media = sorted(set(self.media) - set(MEDIA))
        if not self.media or bad_media:
            raise ValueError(f"media must be some of {', '.join(MEDIA)}, got "
                             f"{','.join(self.media)}")
        if not (self.warmup > 0 and self.tune_seconds > 0 and self.tune_warmup > 0):
            raise ValueError("warmup, tune_seconds and tune_warmup must be > 0 seconds")

    def share_fps(self, medium: str, n: int) -> float:
        """Frames per second per robot the medium carries when N share it: where the
        search for a fixed rate starts."""
        rate = self.channel.rate_bps if medium == "tbf" else self.wifi.capacity_bps
        return share_fps(rate, n, IMAGE_BYTES)


@dataclass(frozen=True)
class Stint:
    """A robot's time in the air: from its start to its stop (wall clock)."""

    robot: int
    start: float
    end: float


@dataclass
class MissionRun:
    """What one system's run of a mission recorded: the ground's frames per robot
    ((delivered, generated) wall-clock pairs), each robot's stints, the channel's bytes
    at every phase's edges (up, down), and each phase's throttle (None: none)."""

    medium: str
    system: str
    mission: Mission
    t0: float
    rates: tuple[float | None, ...]
    frames: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    stints: list[Stint] = field(default_factory=list)
    air: list[tuple[int, int]] = field(default_factory=list)
    load: float = 0.0

    def at(self, offset: float) -> float:
        """Wall-clock time ``offset`` seconds into the mission."""
        return self.t0 + offset

    def save(self, path: Path) -> None:
        """All but the frames (the probe's CSV beside it) as JSON, to report it again."""
        path.write_text(json.dumps({
            "mission": repr(self.mission), "medium": self.medium, "system": self.system,
            "t0": self.t0, "rates": self.rates, "load": self.load, "air": self.air,
            "stints": [[s.robot, s.start, s.end] for s in self.stints]}))

    @classmethod
    def saved(cls, path: Path, mission: Mission) -> MissionRun | None:
        """A run saved by ``save`` (its frames from the CSV of the same name), if it
        flew ``mission`` as it is now; None otherwise."""
        if not path.exists():
            return None
        data = json.loads(path.read_text())
        if data["mission"] != repr(mission):
            return None
        return cls(data["medium"], data["system"], mission, data["t0"], tuple(data["rates"]),
                   read_record(path.with_suffix(".csv")),
                   [Stint(int(r), a, b) for r, a, b in data["stints"]],
                   [(int(u), int(d)) for u, d in data["air"]], data["load"])


def _topic(system: str, robot: int) -> str:
    """What the ground subscribes to for ``robot``: its own topic, or the one the
    leader (or, newest-only, its follower) publishes for it."""
    kind = "wiswarm" if system in ("wiswarm", "newest") else "direct"
    return AirCase(kind, robot).topic(robot)


class _Swarm:
    """The processes of one run, started and stopped robot by robot as the phases go."""

    def __init__(self, medium: Medium, system: str, mission: Mission, rates: Sequence[float | None],
                 t0: float, children: Children, workdir: Path) -> None:
        self.medium, self.system, self.mission = medium, system, mission
        self.rates, self.t0 = rates, t0
        self.children, self.workdir = children, workdir
        self.namespaces = robot_namespaces(medium, max(mission.robots))
        self.ground = ground_placement(medium)
        self.flying: dict[int, tuple[str, float, Cli | None]] = {}  # child, start, follower
        self.stints: list[Stint] = []
        self._count = 0

    def retune(self, since: int) -> tuple[tuple[float, float | None], ...]:
        """The oracle's throttle at each later phase's start (the others keep theirs)."""
        if self.system != "oracle":
            return ()
        return tuple((self.t0 + phase.start, self.rates[i])
                     for i, phase in enumerate(self.mission.phases) if i > since)

    def launch(self, robot: int, phase: int) -> None:
        """Robot ``robot`` takes off in phase ``phase`` (its follower too, if any)."""
        self._count += 1
        name = f"{robot_name(robot)}-{self._count}"
        ns = self.namespaces[robot - 1]
        options = RobotOptions(robot, self.ground.router_endpoint, self.rates[phase],
                               self.retune(phase),
                               NEWEST_ZENOH if self.system == "newest" else ())
        self.children.start(name, run_in, ns, run_robot, options, wait=False)
        follower = None
        if self.system in ("wiswarm", "newest"):
            argv = follower_command(robot) + (list(NEWEST_ONLY) if self.system == "newest"
                                              else [])
            follower = start_cli(ns, argv, self.workdir, f"{self.system}-{name}-follower")
        self.flying[robot] = (name, time.time(), follower)

    def land(self, robot: int) -> None:
        name, start, follower = self.flying.pop(robot)
        if follower is not None:
            stop_cli([follower])
        self.children.stop([name])
        self.stints.append(Stint(robot, start, time.time()))

    def land_all(self) -> None:
        for robot in list(self.flying):
            self.land(robot)

    def pid(self, robot: int) -> int:
        return self.children.pid(self.flying[robot][0])

    def check(self) -> None:
        """RuntimeError naming a process that ended while it should fly."""
        for robot, (name, _, follower) in self.flying.items():
            if not self.children.alive(name):
                raise RuntimeError(f"robot {robot_name(robot)} ended during the run")
            if follower is not None and follower[1].poll() is not None:
                raise RuntimeError(f"a process ended during the run: {follower[0]}")


def degrade(medium: Medium, swarm: _Swarm, robot: int, share: float) -> None:
    """Robot ``robot``'s link at ``share`` of its full rate (1: restored): its flows on
    the tbf uplink capped, or its station's PHY rate lowered on the WiFi medium."""
    if isinstance(medium, Channel):
        if share >= 1.0:
            medium.uncap(swarm.pid(robot))
            return
        deadline = time.monotonic() + CONNECT_WAIT
        while True:  # a robot that just took off may not have reached the ground yet
            try:
                medium.cap_flows_of(swarm.pid(robot), int(medium.spec.rate_bps * share))
                return
            except ValueError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(SUPERVISE_PERIOD)
    medium.set_station_rate(robot, degraded_mode(medium.spec, share))


def degraded_mode(spec: WifiSpec, share: float) -> str:
    """The data mode of the standard's highest rate at most ``share`` of the medium's
    (its lowest if none is): a station that flew away, its rate adaptation stepping
    down."""
    names = ([f"ErpOfdmRate{r}Mbps" for r in ERP_MBPS] if spec.standard == "80211g"
             else [f"HtMcs{k}" for k in range(len(HT_20MHZ_MBPS))])
    rates = [(replace(spec, data_mode=mode).phy_rate_bps, mode) for mode in names]
    fitting = [(rate, mode) for rate, mode in rates if rate <= spec.phy_rate_bps * share + 1]
    return max(fitting)[1] if fitting else min(rates)[1]


def weight_puts(mission: Mission, t0: float) -> tuple[tuple[float, str, str], ...]:
    """Every weight the mission sets, as (wall time, key, text) for the operator."""
    keys = SwarmKeys(SWARM)
    puts = []
    before: Phase | None = None
    for phase in mission.phases:
        for robot in phase.robots:
            weight = phase.weight_of(robot)
            was = None if before is None or robot not in before.robots else \
                before.weight_of(robot)
            if weight != (1.0 if was is None else was):
                puts += [(t0 + phase.start + delay, keys.weight(follower_id(robot)),
                          f"{weight:g}") for delay in WEIGHT_REPEATS]
        before = phase
    return tuple(sorted(puts))


def run_mission(medium: Medium, name: str, mission: Mission, system: str,
                rates: Sequence[float | None], workdir: Path, warmup: float,
                progress: Callable[[str], None] | None = None, tag: str | None = None
                ) -> MissionRun:
    """``system`` through ``mission`` over ``medium`` (called ``name``); ``rates`` is
    each phase's throttle (None: none); its files in ``workdir`` named by ``tag``
    (default: the system). RuntimeError if a process ends during it or the first robots
    are not heard within ``warmup``; MediumFailed if the WiFi medium falls behind real
    time."""
    if len(rates) != len(mission.phases):
        raise ValueError("rates must give one throttle per phase")
    probe = run_file(workdir, name, tag or system).with_suffix(".csv")
    probe.unlink(missing_ok=True)
    t0 = time.time() + warmup
    first = mission.phases[0]
    children = Children(multiprocessing.get_context("spawn"))
    with children:
        swarm = _Swarm(medium, system, mission, rates, t0, children, workdir)
        ground = swarm.ground
        children.start("ground-router", run_in, ground.leader_ns, run_router, ground.router())
        if system == "wiswarm":
            children.start("leader", run_in, ground.leader_ns, run_leader,
                           client_of_local_router(),
                           LeaderOptions(SWARM, bridge=Ros2Options(domain=0)), wait=False)
            children.start("operator", run_in, ground.leader_ns, run_operator,
                           client_of_local_router(), OperatorOptions(weight_puts(mission, t0)),
                           wait=False)
        try:
            for robot in first.robots:
                swarm.launch(robot, 0)
            topics = tuple((robot_name(r), _topic(system, r)) for r in mission.robots)
            children.start("probe", run_in, ground.leader_ns, run_probe,
                           client_of_local_router(),
                           ProbeOptions(topics, str(probe),
                                        tuple(robot_name(r) for r in first.robots)),
                           wait=False)
            children.wait_ready(timeout=max(1.0, t0 - time.time()))
            for robot in first.robots:
                if first.link_of(robot) < 1.0:
                    degrade(medium, swarm, robot, first.link_of(robot))
            air = _fly(medium, swarm, t0, progress)
            children.stop(["probe"])
        finally:
            swarm.land_all()
    run = MissionRun(name, system, mission, t0, tuple(rates), read_record(probe),
                     swarm.stints, air, os.getloadavg()[0])
    run.save(probe.with_suffix(".json"))
    return run


def run_file(workdir: Path, medium: str, tag: str) -> Path:
    """Where a run of ``tag`` (a system, or a static run's name) on ``medium`` is saved."""
    return workdir / f"{medium}-{tag}.json"


def _fly(medium: Medium, swarm: _Swarm, t0: float,
         progress: Callable[[str], None] | None) -> list[tuple[int, int]]:
    """Every phase at its time; the channel's bytes at each phase's edges."""
    wifi = medium if isinstance(medium, WifiMedium) else None
    phases = swarm.mission.phases
    air: list[tuple[int, int]] = []
    for index, phase in enumerate(phases):
        _supervise(swarm, wifi, t0 + phase.start)
        air.append(air_bytes(medium))
        if progress is not None:
            progress(phase.name)
        if index > 0:
            before = phases[index - 1]
            for robot in before.robots:
                if robot not in phase.robots:
                    swarm.land(robot)
            for robot in phase.robots:
                if robot not in before.robots:
                    swarm.launch(robot, index)
            for robot in phase.robots:
                was = before.link_of(robot) if robot in before.robots else 1.0
                if phase.link_of(robot) != was:
                    degrade(medium, swarm, robot, phase.link_of(robot))
    _supervise(swarm, wifi, t0 + phases[-1].end)
    air.append(air_bytes(medium))
    return air


def _supervise(swarm: _Swarm, wifi: WifiMedium | None, until: float) -> None:
    while (left := until - time.time()) > 0:
        time.sleep(min(SUPERVISE_PERIOD, left))
        swarm.check()
        if wifi is not None:
            wifi.check()


MediumFactory = Callable[[], contextlib.AbstractContextManager[Medium]]


@contextlib.contextmanager
def media(config: MissionConfig, name: str) -> Iterator[MediumFactory]:
    """A medium for each run: a fresh tbf channel, or the one WiFi medium (a station
    for every robot the mission flies)."""
    if name == "tbf":
        yield lambda: Channel(config.channel)
        return
    stations = max(config.mission.robots)
    with WifiMedium(replace(config.wifi, stations=stations)) as wifi:
        yield lambda: contextlib.nullcontext(wifi)
