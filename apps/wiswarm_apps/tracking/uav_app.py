"""A sensing-UAV process (paper, Section III-C): camera frames out, waypoints in.

The camera takes a frame at `rate_hz` (100 fps for WiSwarm, as in the paper) and offers
it to the middleware: a ``Follower`` with a LIFO queue of one frame, answering polls,
or the push baseline's FIFO sender. Control information goes through the waypoint
guard (a NaN or out-of-arena plan is rejected with a logged reason and the last safe
plan is flown). A sampler measures tracking error against the car's true position,
which this process knows from the seeded world; the measurements are published for
the live table on ``wiswarm/<swarm>/<uav>/tracking`` and handed back at the end.

Clocks: the UAV's clock is `time.time()`; world time is `now - epoch`, the epoch being
shared by the demo. Samples are taken in [epoch, epoch + duration_s] only; at its end
the process hands its results back and ends.
"""

from __future__ import annotations

import json
import logging
import math
import multiprocessing
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import asdict, dataclass, field
from multiprocessing.connection import Connection

import numpy as np
import zenoh

from wiswarm_apps.tracking.frames import encode_frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.kinds import SYSTEMS, VEHICLE_KINDS, System, VehicleKind
from wiswarm_apps.tracking.metrics import UavMetrics
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.vehicles import Vehicle, open_vehicle
from wiswarm_apps.tracking.world import World, WorldConfig
from wiswarm_zenoh import Follower, FollowerConfig, Waypoint
from wiswarm_zenoh.baselines import DEFAULT_CAPACITY, PushSender
from wiswarm_zenoh.programs import (
    SUPERVISION_PERIOD,
    ReadySignal,
    StopSignal,
    Ticker,
    wait_until_stopped,
)
from wiswarm_zenoh.transport import BadInputLog, ControlListener, SessionSpec, SwarmKeys

log = logging.getLogger(__name__)

TRACKING_LEAF = "tracking"
START_OFFSET_M = (0.3, -0.2)  # the UAV starts near its car, not exactly above it
SAMPLE_FIELDS = ("t", "uav_x", "uav_y", "uav_z", "uav_yaw", "car_x", "car_y", "error_m", "error_px",
                 "in_view", "control_age_s")


def tracking_key(keys: SwarmKeys, uav: str) -> str:
    return f"{keys.prefix}/{uav}/{TRACKING_LEAF}"


@dataclass(frozen=True)
class UavOptions:
    """One UAV process: which car it tracks, how it talks, how long it measures."""

    swarm: str
    uav: str
    car: int
    world: WorldConfig
    system: System = "wiswarm"
    rate_hz: float = 100.0
    duration_s: float = 30.0
    camera: CameraModel = field(default_factory=CameraModel)
    vehicle: VehicleKind = "virtual"
    altitude_m: float = 2.0
    max_speed_mps: float = 2.0
    ground_resolution_m: float = 0.01
    sample_hz: float = 20.0
    push_fifo: int = DEFAULT_CAPACITY  # frames: the middleware's push FIFO

    def __post_init__(self) -> None:
        if self.system not in SYSTEMS:
            raise ValueError(f"system must be one of {SYSTEMS}, got {self.system!r}")
        if self.vehicle not in VEHICLE_KINDS:
            raise ValueError(f"vehicle must be one of {VEHICLE_KINDS}, got {self.vehicle!r}")
        if not 0 <= self.car < self.world.n_cars:
            raise ValueError(f"car {self.car} is not one of the world's {self.world.n_cars}")
        for name in ("rate_hz", "duration_s", "sample_hz", "altitude_m", "max_speed_mps"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if self.rate_hz > 1000:
            raise ValueError(f"rate_hz must be at most 1000, got {self.rate_hz!r}")
        if not self.altitude_m <= self.world.arena.max_altitude_m:
            raise ValueError(f"altitude_m {self.altitude_m} is above the arena's ceiling")

    def start_pose(self) -> Pose:
        """Near the car's starting place, at tracking altitude, a seeded heading."""
        x, y = World(self.world).car_position(self.car, 0.0)
        arena = self.world.arena
        rng = np.random.default_rng([self.world.seed, self.car])
        return Pose(min(max(x + START_OFFSET_M[0], 0.0), arena.width_m),
                    min(max(y + START_OFFSET_M[1], 0.0), arena.height_m),
                    self.altitude_m, float(rng.uniform(-math.pi, math.pi)))


@dataclass(frozen=True)
class UavResult:
    """What a UAV process hands back: metrics summary, counters, samples (world time)."""

    uav: str
    summary: dict[str, float]
    counters: dict[str, int]
    samples: list[tuple[float, ...]]  # SAMPLE_FIELDS


GO, STOP = "go", "stop"


class UavLink:
    """The demo's line to one UAV process: a pipe (no lock is shared between processes,
    so a killed process cannot wedge the others). Down: ("go", epoch), then maybe
    ("stop",) to end early. Up: the UavResult, once."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection

    def go(self, epoch: float) -> None:
        self._connection.send((GO, epoch))

    def stop(self) -> None:
        self._connection.send((STOP,))

    def wait_go(self, stop: StopSignal) -> float | None:
        """The world epoch, or None if stopped (or the parent went) before it came."""
        parent = multiprocessing.parent_process()
        while not stop.is_set() and (parent is None or parent.is_alive()):
            if self._connection.poll(SUPERVISION_PERIOD):
                message = self._connection.recv()
                return float(message[1]) if message[0] == GO else None
        return None

    def stop_requested(self) -> bool:
        return self._connection.poll() and self._connection.recv()[0] == STOP

    def send_result(self, result: UavResult) -> None:
        self._connection.send(result)

    def fileno(self) -> int:
        """For ``multiprocessing.connection.wait``: the demo waits on all links at once."""
        return self._connection.fileno()

    def result(self, timeout: float) -> UavResult | None:
        if not self._connection.poll(timeout):
            return None
        result: UavResult = self._connection.recv()
        return result


class UavRuntime:
    """Camera, control, sampler and stats of one UAV on an open session."""

    def __init__(self, session: zenoh.Session, options: UavOptions, renderer: Renderer,
                 epoch: float) -> None:
        self.options = options
        self.world = renderer.world
        self.epoch = epoch
        self.end = epoch + options.duration_s
        self.metrics = UavMetrics(options.uav, options.camera)
        self.frames = 0
        self.frames_in_window = 0
        self.frames_missed = 0
        self._stack = ExitStack()
        self._node: Follower | None = None
        self._bad_control: list[BadInputLog] = []
        try:
            self.vehicle: Vehicle = self._stack.enter_context(open_vehicle(
                options.vehicle, options.uav, options.start_pose(), renderer, options.camera,
                epoch, options.max_speed_mps,
            ))
            self._offer = self._open_transport(session)
            self._publisher = self._stack.enter_context(session.declare_publisher(
                tracking_key(SwarmKeys(options.swarm), options.uav),
                encoding=zenoh.Encoding.APPLICATION_JSON,
            ))
            for ticker in (Ticker(options.rate_hz, self._capture, f"camera-{options.uav}"),
                           Ticker(options.sample_hz, self._sample, f"sampler-{options.uav}")):
                ticker.start()
                self._stack.callback(ticker.stop)
        except BaseException:
            self._stack.close()
            raise

    def _open_transport(self, session: zenoh.Session) -> Callable[[bytes], bool]:
        """The middleware end: a follower node (LIFO of one) or the push sender (FIFO)."""
        options = self.options
        if options.system == "wiswarm":
            node = Follower(session, options.swarm, options.uav,
                            config=FollowerConfig(queue="lifo", capacity=1),
                            on_control=self._on_control)
            self._stack.callback(node.close)
            self._node = node
            self._bad_control.append(node.bad_input)
            return node.offer
        sender = PushSender(session, options.swarm, options.uav, capacity=options.push_fifo)
        self._stack.callback(sender.close)
        listener = ControlListener(session, options.swarm, options.uav, self._on_control)
        self._stack.callback(listener.close)
        self._bad_control.append(listener.bad_input)
        return sender.offer

    def _on_control(self, waypoints: list[Waypoint]) -> None:
        if self.vehicle.set_waypoints(waypoints):
            self.metrics.control_received(waypoints[0][0])

    def _capture(self, now: float) -> None:
        frame = self.vehicle.capture(now)
        if frame is None:
            self.frames_missed += 1
            return
        self._offer(encode_frame(frame))
        self.frames += 1
        self.frames_in_window += self.epoch <= now <= self.end

    def _sample(self, now: float) -> None:
        if not self.epoch <= now <= self.end:
            return
        pose = self.vehicle.pose_at(now)
        if pose is not None:
            self.metrics.record(now, pose, self.world.car_position(self.options.car,
                                                                   now - self.epoch))

    def publish_stats(self) -> None:
        """The live table's row and the dashboard's map entry for this UAV (JSON on the
        tracking key). Besides the row's fields: ``t`` (now, UAV clock), ``arena``
        ([width, height]), ``car`` (its index), ``car_x``/``car_y`` (its true place),
        ``x``/``y``/``z``/``yaw`` (the UAV's pose; absent while a MAVLink link is down),
        ``footprint`` (the ground corners of the camera frame) and ``waypoints`` (the plan
        flown, [t, x, y, z], t in the UAV's clock). Metres and radians, world frame."""
        samples = self.metrics.samples
        record: dict[str, object] = {"uav": self.options.uav, "frames": self.frames,
                                     "rejected_waypoints": self.vehicle.guard.rejected,
                                     **self._whereabouts(time.time())}
        if samples:
            last, summary = samples[-1], self.metrics.summary()
            record.update(error_m=last.error_m, in_view=last.in_view,
                          control_age_s=last.control_age_s,
                          mean_error_m=summary.mean_tracking_error_m,
                          in_view_share=summary.in_view_share)
        self._publisher.put(json.dumps(record, separators=(",", ":")))

    def _whereabouts(self, now: float) -> dict[str, object]:
        """Where the UAV, its car, its camera's footprint and its plan are at ``now``:
        what only this process knows at every instant, for a map of the arena."""
        arena, camera = self.world.arena, self.options.camera
        car_x, car_y = self.world.car_position(self.options.car, now - self.epoch)
        record: dict[str, object] = {
            "t": now, "arena": [arena.width_m, arena.height_m], "car": self.options.car,
            "car_x": car_x, "car_y": car_y,
            "waypoints": [list(waypoint) for waypoint in self.vehicle.guard.plan]}
        pose = self.vehicle.pose_at(now)
        if pose is not None:  # None while a MAVLink link is down
            right, bottom = camera.width - 0.5, camera.height - 0.5
            record.update(x=pose.x, y=pose.y, z=pose.z, yaw=pose.yaw, footprint=[
                list(camera.pixel_to_world(pose, u, v))
                for u, v in ((-0.5, -0.5), (right, -0.5), (right, bottom), (-0.5, bottom))])
        return record

    def close(self) -> None:
        self._stack.close()

    def result(self) -> UavResult:
        guard = self.vehicle.guard
        counters = {"frames": self.frames, "frames_in_window": self.frames_in_window,
                    "frames_missed": self.frames_missed,
                    "waypoints_accepted": guard.accepted, "waypoints_rejected": guard.rejected,
                    "polls": self._node.polls if self._node is not None else 0,
                    "bad_control": sum(bad.total() for bad in self._bad_control)}
        summary = {k: float(v) for k, v in asdict(self.metrics.summary()).items()}
        samples: list[tuple[float, ...]] = [
            (s.t - self.epoch, s.uav.x, s.uav.y, s.uav.z, s.uav.yaw, s.car_x, s.car_y, s.error_m,
             s.error_px, float(s.in_view),
             math.nan if s.control_age_s is None else s.control_age_s)
            for s in self.metrics.samples
        ]
        return UavResult(self.options.uav, summary, counters, samples)


def run_uav(spec: SessionSpec, options: UavOptions, link: UavLink, stop: StopSignal,
            ready: ReadySignal) -> None:
    """A UAV process: get ready, wait for the start, fly to the end of the window (or
    until stopped), hand back the results."""
    renderer = Renderer(World(options.world), options.ground_resolution_m)
    with spec.open() as session:
        ready.set()
        epoch = link.wait_go(stop)
        if epoch is None:
            return
        runtime = UavRuntime(session, options, renderer, epoch)

        def tick() -> None:
            runtime.publish_stats()
            if link.stop_requested():
                stop.set()

        try:
            wait_until_stopped(stop, runtime.end - time.time(), tick)
        finally:
            runtime.close()
    link.send_result(runtime.result())
    log.info("%s: %d frames taken", options.uav, runtime.frames)
