"""The tracking demo: an embedded router, N UAV processes (spawn) and the leader here.

Order of events: over the shared link in user space its relay comes up first, in a
process of its own; the router comes up; the UAVs build the seeded world and open their
sessions, then report ready (started together by the transport's `Children`, which
also stops them all on the way out); this process opens the leader's session, its
vision thread and transport (polling or push); the world epoch is set a warm-up ahead and
every UAV is told to go, through its own pipe. During the warm-up the cars stand still
and each UAV settles over its car; the measurement window is [epoch, epoch + duration].
At its end the UAVs hand back their measurements and end. Children ignore Ctrl-C: it
ends the window early here, the UAVs are told to stop, and the run is reported as far
as it went. The dashboard goes with the run, or, handed a caller's stack to keep it
(``wiswarm demo --keep-dashboard``), stops listening and serves the run's end until
that stack closes.
"""

from __future__ import annotations

import logging
import math
import multiprocessing
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field, replace
from multiprocessing import connection
from pathlib import Path
from typing import Literal

import zenoh

from wiswarm_apps.tracking.board import TrackingBoard, table_lines
from wiswarm_apps.tracking.geometry import CameraModel
from wiswarm_apps.tracking.kinds import FRAME_SIZES, SYSTEMS, VEHICLE_KINDS, System, VehicleKind
from wiswarm_apps.tracking.leader_app import CarEstimate, ControlSink, VisionLoop, VisionStats
from wiswarm_apps.tracking.push import PushLeader
from wiswarm_apps.tracking.reception import AoISummary, DeliveryRow, Reception
from wiswarm_apps.tracking.ros2 import CarMarkers, FrameAdapter
from wiswarm_apps.tracking.tracker import TrackerConfig
from wiswarm_apps.tracking.uav_app import UavLink, UavOptions, UavResult, run_uav
from wiswarm_apps.tracking.world import MOTIONS, Motion, WorldConfig
from wiswarm_zenoh import Leader, LeaderConfig
from wiswarm_zenoh.core import POLICIES
from wiswarm_zenoh.dashboard import DEFAULT_PORT, Dashboard
from wiswarm_zenoh.programs import Children, LiveTable, run_router, wait_until_stopped
from wiswarm_zenoh.recording import DEFAULT_PORT as FOXGLOVE_PORT
from wiswarm_zenoh.recording import SwarmRecording
from wiswarm_zenoh.ros2 import Ros2Bridge, Ros2Options
from wiswarm_zenoh.testbed import (
    Channel,
    ChannelSpec,
    Placement,
    UserChannel,
    WifiMedium,
    WifiSpec,
    entered,
    run_in,
    run_link,
)
from wiswarm_zenoh.transport import SessionSpec, free_tcp_port

log = logging.getLogger(__name__)

SWARM = "tracking"
RESULT_TIMEOUT_S = 15.0
CHECK_PERIOD = 0.25  # seconds between checks, while waiting for results, that UAVs live
DEFAULT_RATE = {"wiswarm": 100.0, "push": 50.0}  # the paper: 100 fps LIFO, 50 fps FIFO
ChannelKind = Literal["user", "tbf", "wifi"]
CHANNEL_KINDS: tuple[ChannelKind, ...] = ("user", "tbf", "wifi")


@dataclass(frozen=True)
class DemoOptions:
    """A demo run; every field is checked on construction (ValueError names it)."""

    uavs: int = 4
    duration_s: float = 30.0
    seed: int = 0
    system: System = "wiswarm"
    rate_hz: float | None = None
    frame_px: int = 224
    vehicle: VehicleKind = "virtual"
    motion: Motion = "random_walk"
    mode: Literal["peer", "client"] = "peer"
    policy: str = "whittle"
    warmup_s: float = 2.0
    live: bool = False
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    # the UAVs behind a shared channel of this shape, or each a station of the WiFi medium
    channel: ChannelSpec | WifiSpec | None = None
    # tbf: namespaces (root); user: a relay on loopback; wifi: ns-3's medium (root)
    channel_kind: ChannelKind = "tbf"
    dashboard_port: int | None = DEFAULT_PORT  # the live page (None: none)
    ros2: Ros2Options | None = None  # the leader is also a ROS 2 node
    mcap: Path | None = None  # where the run is recorded for Foxglove (None: not recorded)

    def __post_init__(self) -> None:
        if isinstance(self.uavs, bool) or not 1 <= self.uavs <= 50:
            raise ValueError(f"uavs must be in [1, 50], got {self.uavs!r}")
        if not (math.isfinite(self.duration_s) and 1.0 <= self.duration_s <= 86400):
            raise ValueError(f"duration must be in [1, 86400] s, got {self.duration_s!r}")
        if self.rate_hz is not None and not (math.isfinite(self.rate_hz)
                                             and 0 < self.rate_hz <= 1000):
            raise ValueError(f"rate must be in (0, 1000] frames/s, got {self.rate_hz!r}")
        if self.system not in SYSTEMS:
            raise ValueError(f"system must be one of {SYSTEMS}, got {self.system!r}")
        if self.frame_px not in FRAME_SIZES:
            raise ValueError(f"frame size must be one of {FRAME_SIZES}, got {self.frame_px!r}")
        if self.vehicle not in VEHICLE_KINDS:
            raise ValueError(f"vehicle must be one of {VEHICLE_KINDS}, got {self.vehicle!r}")
        if self.motion not in MOTIONS:
            raise ValueError(f"motion must be one of {MOTIONS}, got {self.motion!r}")
        if self.mode not in ("peer", "client"):
            raise ValueError(f"mode must be peer or client, got {self.mode!r}")
        if self.policy not in POLICIES:
            raise ValueError(f"policy must be one of {sorted(POLICIES)}, got {self.policy!r}")
        if not (math.isfinite(self.warmup_s) and 0.5 <= self.warmup_s <= 60):
            raise ValueError(f"warm-up must be in [0.5, 60] s, got {self.warmup_s!r}")
        if self.channel_kind not in CHANNEL_KINDS:
            raise ValueError(f"channel kind must be one of {CHANNEL_KINDS}, got "
                             f"{self.channel_kind!r}")
        if (self.channel is not None
                and isinstance(self.channel, WifiSpec) != (self.channel_kind == "wifi")):
            raise ValueError("the wifi channel kind goes with a WifiSpec, user and tbf with "
                             f"a ChannelSpec, got {self.channel_kind!r} with "
                             f"{type(self.channel).__name__}")
        if self.ros2 is not None and self.system != "wiswarm":
            raise ValueError("--ros2 is for --system wiswarm: the push baseline has no leader")
        if self.dashboard_port is not None and self.namespaces:
            raise ValueError(f"the dashboard cannot run with --channel {self.channel_kind}: "
                             "its page would "
                             "listen inside the leader's network namespace (add "
                             "--no-dashboard)")
        self.world_config()  # the world must fit the UAVs' cars

    @property
    def namespaces(self) -> bool:
        """Whether the run builds network namespaces (root): the tbf channel's or the
        WiFi medium's."""
        return self.channel is not None and self.channel_kind in ("tbf", "wifi")

    @property
    def rate(self) -> float:
        return self.rate_hz if self.rate_hz is not None else DEFAULT_RATE[self.system]

    @property
    def camera(self) -> CameraModel:
        return CameraModel(width=self.frame_px, height=self.frame_px)

    @property
    def uav_ids(self) -> list[str]:
        return [f"uav{i}" for i in range(self.uavs)]

    def world_config(self) -> WorldConfig:
        """One car per UAV, driving for the warm-up and the window (and a margin)."""
        return WorldConfig(n_cars=self.uavs, motion=self.motion, seed=self.seed,
                           duration_s=self.duration_s + 60.0)

    def uav_options(self, index: int) -> UavOptions:
        return UavOptions(
            swarm=SWARM, uav=self.uav_ids[index], car=index, world=self.world_config(),
            system=self.system, rate_hz=self.rate, duration_s=self.duration_s,
            camera=self.camera, vehicle=self.vehicle, altitude_m=self.tracker.altitude_m,
        )


@dataclass(frozen=True)
class DemoRun:
    """Everything measured: the leader's AoI and vision, the UAVs' own measurements."""

    options: DemoOptions
    epoch: float
    measured_s: float
    aoi: dict[str, AoISummary]
    vision: dict[str, VisionStats]
    vision_busy_s: float
    deliveries: list[DeliveryRow]
    uavs: dict[str, UavResult]
    polls: int
    dashboard_url: str | None = None  # where the run's page was (or still is) served


@dataclass
class _Leader:
    sink: ControlSink
    weights: Callable[[], dict[str, float]]
    polls: Callable[[], int]
    on_estimate: Callable[[CarEstimate], None] | None = None  # the cars, to ROS 2


@contextmanager
def _open_leader(session: zenoh.Session, options: DemoOptions,
                 reception: Reception) -> Iterator[_Leader]:
    """The leader's transport: a ``Leader`` polling, or the push baseline's subscriber."""
    if options.system == "wiswarm":
        config = LeaderConfig(policy=options.policy)
        with Leader(session, SWARM, reception.on_delivered, config=config,
                    bridge=options.ros2, every_record=True) as node:  # weights shown
            yield _Leader(
                node, lambda: {r.follower: r.weight for r in node.stats},
                lambda: node.polls,
                CarMarkers(node.bridge) if isinstance(node.bridge, Ros2Bridge) else None,
            )
    else:
        leader = PushLeader(session, SWARM, reception)
        try:
            yield _Leader(leader, leader.weights, lambda: 0)
        finally:
            leader.close()


@dataclass(frozen=True)
class _Sides:
    """Where the router, the UAVs and the leader run, and with which sessions."""

    router: SessionSpec
    uav: SessionSpec
    leader: SessionSpec
    leader_ns: str | None = None  # None: all on this host's loopback
    uav_ns: tuple[str | None, ...] = (None,)  # UAV i's: its own, or all one side's
    link: UserChannel | None = None  # the user-space link's relay, started first

    def uav_ns_of(self, index: int) -> str | None:
        return self.uav_ns[index % len(self.uav_ns)]


def _sides(options: DemoOptions, stack: ExitStack) -> _Sides:
    """Loopback, the two ends of a user-space link, or the two sides of an emulated
    channel or WiFi medium built for this run."""
    if options.channel is None:
        port = free_tcp_port()
        uav = SessionSpec.loopback(options.mode, connect_ports=[port])
        return _Sides(SessionSpec.loopback("router", port), uav, uav)
    if isinstance(options.channel, WifiSpec):
        medium = stack.enter_context(WifiMedium(replace(options.channel,
                                                        stations=options.uavs)))
        log.info("%s", medium.describe())
        stations = tuple(medium.station_namespaces)
        place = Placement(medium.leader_ns, stations[0], medium.leader_addr)
        return _Sides(place.router(), place.follower(), place.leader(), medium.leader_ns,
                      stations)
    if options.channel_kind == "user":
        link = UserChannel.on_free_ports(options.channel)
        log.info("%s", link.describe())
        return _Sides(link.router(), link.follower(), link.leader(), link=link)
    channel = stack.enter_context(Channel(options.channel))
    log.info("%s", channel.describe())
    place = Placement(channel.leader_ns, channel.follower_ns, channel.leader_addr)
    return _Sides(place.router(), place.follower(), place.leader(), channel.leader_ns,
                  (channel.follower_ns,))


def _start(children: Children, name: str, ns: str | None, target: Callable[..., object],
           *args: object, wait: bool = True) -> None:
    if ns is None:
        children.start(name, target, *args, wait=wait)
    else:
        children.start(name, run_in, ns, target, *args, wait=wait)


def run(options: DemoOptions, pages: ExitStack | None = None) -> DemoRun:
    """Run the demo and return its measurements (no files are written here). With
    ``pages``, the run's dashboard outlives it: it stops listening as the run ends and
    serves the run's last state until ``pages`` closes."""
    world = options.world_config()
    ctx = multiprocessing.get_context("spawn")
    with ExitStack() as stack:
        sides = _sides(options, stack)
        children = stack.enter_context(Children(ctx))
        if sides.link is not None:
            children.start("link", run_link, sides.link)
        _start(children, "router", sides.leader_ns, run_router, sides.router)
        links: dict[str, UavLink] = {}
        for index, uav in enumerate(options.uav_ids):
            mine, theirs = ctx.Pipe()
            links[uav] = UavLink(mine)
            _start(children, uav, sides.uav_ns_of(index), run_uav, sides.uav,
                   options.uav_options(index), UavLink(theirs), wait=False)
        children.wait_ready()

        if sides.leader_ns is not None:  # this thread opens the leader's session inside
            stack.enter_context(entered(sides.leader_ns))
        session = stack.enter_context(sides.leader.open())
        vision = VisionLoop({uav: i for i, uav in enumerate(options.uav_ids)},
                            world.arena, options.tracker, options.camera)
        reception = Reception(options.uav_ids, vision)
        leader = stack.enter_context(_open_leader(session, options, reception))
        vision.start(leader.sink, leader.on_estimate)
        stack.callback(vision.stop)
        board = TrackingBoard(session, SWARM)
        stack.callback(board.close)
        url = None
        if options.dashboard_port is not None:
            page = _dashboard(session, options, kept=pages is not None)
            url = page.url
            if pages is None:
                stack.callback(page.close)
            else:  # served on by the caller; no longer fed once the session is closing
                pages.callback(page.close)
                stack.callback(page.finish)
        if options.mcap is not None or options.dashboard_port is not None:
            stack.enter_context(_foxglove(session, options))

        epoch = time.time() + options.warmup_s
        end = epoch + options.duration_s
        reception.open_window(epoch, end)
        for link in links.values():
            link.go(epoch)
        table = LiveTable() if options.live else None

        def tick() -> None:
            if table is None:
                return
            now = time.time()
            title = (f"{options.system}: {options.uavs} UAVs, "
                     + (f"warm-up {epoch - now:4.1f} s" if now < epoch
                        else f"t = {now - epoch:5.1f} / {options.duration_s:g} s"))
            table.show([title, *table_lines(options.uav_ids, now - epoch,
                                            reception.summary(now), vision.stats(),
                                            board.latest(), leader.weights())])

        wait_until_stopped(threading.Event(), end - time.time(), tick)
        measured = min(max(time.time(), epoch), end) - epoch
        aoi, stats = reception.summary(epoch + measured), vision.stats()
        polls = leader.polls()
        if measured < options.duration_s:  # cut short (Ctrl-C): the UAVs stop too
            for link in links.values():
                link.stop()
        uav_results = _collect(links, children)
    return DemoRun(options, epoch, measured, aoi, stats, vision.busy_s, reception.rows(),
                   uav_results, polls, url)


def _dashboard(session: zenoh.Session, options: DemoOptions, kept: bool) -> Dashboard:
    """The live page of the demo's swarm, on another port if the one asked for is taken
    (another dashboard runs); its address on stderr, and whether it stays after."""
    assert options.dashboard_port is not None
    try:
        page = Dashboard(session, SWARM, options.dashboard_port)
    except OSError as exc:
        log.warning("port %d: %s; the dashboard takes a free one", options.dashboard_port,
                    exc.strerror or exc)
        page = Dashboard(session, SWARM, 0)
    when = ("live while the run lasts, then its end until Ctrl-C" if kept
            else "live while the demo runs")
    print(f"dashboard: {page.url} ({when})", file=sys.stderr, flush=True)
    return page


def _foxglove(session: zenoh.Session, options: DemoOptions) -> SwarmRecording:
    """The run into ``options.mcap`` and, beside the dashboard, live to Foxglove (on a
    free port if Foxglove's own is taken); the live address on stderr."""
    live = options.dashboard_port is not None
    try:
        recording = SwarmRecording(session, SWARM, mcap=options.mcap, adapter=FrameAdapter(),
                                   port=FOXGLOVE_PORT if live else None)
    except RuntimeError as exc:
        log.warning("port %d: %s; Foxglove's server takes a free one", FOXGLOVE_PORT, exc)
        recording = SwarmRecording(session, SWARM, mcap=options.mcap, adapter=FrameAdapter(),
                                   port=0)
    if recording.url is not None:
        print(f"foxglove: {recording.url} (open it in the Foxglove app while the demo runs)",
              file=sys.stderr, flush=True)
    return recording


def _collect(links: dict[str, UavLink], children: Children) -> dict[str, UavResult]:
    """The UAVs' results, as many as arrive in time; a UAV whose process has ended
    without one is not waited for (a missing one is logged)."""
    collected: dict[str, UavResult] = {}
    waiting = dict(links)
    deadline = time.monotonic() + RESULT_TIMEOUT_S
    while waiting:
        for uav, link in list(waiting.items()):
            running = children.alive(uav)  # asked first: a result sent just before exit is read
            result = link.result(0.0)
            if result is not None:
                collected[uav] = result
            elif running:
                continue
            del waiting[uav]
        left = deadline - time.monotonic()
        if not waiting or left <= 0:
            break
        connection.wait([link.fileno() for link in waiting.values()], min(left, CHECK_PERIOD))
    if len(collected) < len(links):
        log.warning("only %d of %d UAVs handed back their measurements",
                    len(collected), len(links))
    return collected
