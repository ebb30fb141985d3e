"""Follower-side MAVLink bridge (pymavlink): vehicle pose in, position setpoints out.

One I/O thread reads LOCAL_POSITION_NED and ATTITUDE (to stamp camera frames with the
pose at capture time), sends a 1 Hz companion heartbeat, and streams the waypoint due
next as SET_POSITION_TARGET_LOCAL_NED (autopilots drop out of guided/offboard control
without a steady setpoint stream). Connection strings are pymavlink's (`udpin:`,
`udpout:`, `tcp:`, serial device). A dropped link is logged, reported through
`connected`, and reopened; nothing raises into the caller.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pymavlink import mavutil

from wiswarm_apps.tracking.frames import Frame
from wiswarm_apps.tracking.geometry import (
    Arena,
    CameraModel,
    Pose,
    pose_from_ned,
    world_to_ned,
)
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.waypoints import WaypointGuard

log = logging.getLogger(__name__)
mavlink = mavutil.mavlink

POSITION_ONLY = (
    mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
)
NOT_VEHICLES = frozenset({mavlink.MAV_TYPE_GCS, mavlink.MAV_TYPE_ONBOARD_CONTROLLER})
MAX_EXTRAPOLATION_S = 0.1  # pose messages come at ~30 Hz: bridge at most a few gaps
Vector3 = tuple[float, float, float]


@dataclass(frozen=True)
class VehicleState:
    """Latest pose report: NED position/velocity, yaw, and local receive time."""

    ned: Vector3
    velocity_ned: Vector3
    yaw_ned: float
    received_at: float


class MavlinkBridge:
    """Links one follower to its flight controller. Call `start()`, then `stop()`."""

    def __init__(self, connection: str, arena: Arena, name: str = "uav",
                 setpoint_hz: float = 20.0, link_timeout_s: float = 2.0,
                 reconnect_delay_s: float = 1.0,
                 clock: Callable[[], float] = time.time) -> None:
        if not 0.5 <= setpoint_hz <= 500:
            raise ValueError(f"setpoint_hz must be in [0.5, 500], got {setpoint_hz!r}")
        if not 0 < link_timeout_s <= 60:
            raise ValueError(f"link_timeout_s must be in (0, 60], got {link_timeout_s!r}")
        self.connection = connection
        self.name = name
        self.guard = WaypointGuard(arena, name)
        self.setpoints_sent = 0
        self.link_errors = 0
        self.last_error: str | None = None
        self._setpoint_period = 1.0 / setpoint_hz
        self._link_timeout = link_timeout_s
        self._reconnect_delay = reconnect_delay_s
        self._clock = clock
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._connected = threading.Event()
        self._vehicle: tuple[int, int] | None = None
        self._heartbeat_at = -float("inf")  # monotonic time of the last vehicle heartbeat
        self._position: tuple[Vector3, Vector3, float] | None = None  # NED, velocity, received
        self._yaw_ned: float | None = None
        self._boot = time.monotonic()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Open the link (raises if pymavlink rejects the connection string) and run."""
        if self._thread is not None:
            raise RuntimeError("bridge already started")
        conn = self._open()
        self._thread = threading.Thread(
            target=self._run, args=(conn,), name=f"mavlink-{self.name}", daemon=True
        )
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    @property
    def connected(self) -> bool:
        return self._connected.is_set()

    def wait_connected(self, timeout: float) -> bool:
        return self._connected.wait(timeout)

    def set_waypoints(self, waypoints: Sequence[Sequence[float]]) -> bool:
        """Adopt a plan (True) or reject it with a logged reason and hold (False)."""
        return self.guard.offer(waypoints)

    def state(self) -> VehicleState | None:
        """The latest pose report, or None while not connected or before one came."""
        with self._lock:
            if not self._connected.is_set() or self._position is None or self._yaw_ned is None:
                return None
            ned, velocity, received_at = self._position
            return VehicleState(ned, velocity, self._yaw_ned, received_at)

    def pose_at(self, now: float) -> Pose | None:
        """World pose at `now` (bridge clock): the latest report moved on by its velocity
        for up to MAX_EXTRAPOLATION_S. None while the link is down."""
        state = self.state()
        if state is None:
            return None
        lag = min(max(now - state.received_at, 0.0), MAX_EXTRAPOLATION_S)
        n, e, d = (p + v * lag for p, v in zip(state.ned, state.velocity_ned, strict=True))
        return pose_from_ned(n, e, d, state.yaw_ned)

    def _open(self) -> Any:
        return mavutil.mavlink_connection(
            self.connection, source_system=255,
            source_component=mavlink.MAV_COMP_ID_ONBOARD_COMPUTER,
        )

    def _run(self, conn: Any) -> None:
        next_heartbeat = next_setpoint = time.monotonic()
        while not self._stop.is_set():
            try:
                if conn is None:
                    conn = self._open()
                    log.info("%s: reopened MAVLink link %s", self.name, self.connection)
                now = time.monotonic()
                wait = max(0.001, min(next_heartbeat, next_setpoint) - now)
                message = conn.recv_match(blocking=True, timeout=min(wait, 0.05))
                while message is not None:
                    self._handle(message)
                    message = conn.recv_match(blocking=False)
                now = time.monotonic()
                self._check_link(now)
                if now >= next_heartbeat:
                    conn.mav.heartbeat_send(mavlink.MAV_TYPE_ONBOARD_CONTROLLER,
                                            mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                    next_heartbeat = now + 1.0
                if now >= next_setpoint:
                    self._send_setpoint(conn)
                    next_setpoint = now + self._setpoint_period
            except Exception as exc:  # any link failure: log, reopen, never crash
                self.link_errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
                log.warning("%s: MAVLink link error, reopening in %.1f s: %s",
                            self.name, self._reconnect_delay, self.last_error)
                self._set_disconnected("link error")
                self._close(conn)
                conn = None
                self._stop.wait(self._reconnect_delay)
        self._close(conn)

    @staticmethod
    def _close(conn: Any) -> None:
        if conn is not None:
            try:
                conn.close()
            except OSError as exc:
                log.debug("closing MAVLink link: %s", exc)

    def _handle(self, message: Any) -> None:
        kind = message.get_type()
        source = (int(message.get_srcSystem()), int(message.get_srcComponent()))
        if kind == "HEARTBEAT":
            if message.type in NOT_VEHICLES:
                return
            with self._lock:
                self._vehicle = source
                self._heartbeat_at = time.monotonic()
            if not self._connected.is_set():
                log.info("%s: vehicle %s/%s connected", self.name, *source)
                self._connected.set()
        elif self._vehicle is None or source[0] != self._vehicle[0]:
            return
        elif kind == "LOCAL_POSITION_NED":
            with self._lock:
                self._position = (
                    (float(message.x), float(message.y), float(message.z)),
                    (float(message.vx), float(message.vy), float(message.vz)),
                    self._clock(),
                )
        elif kind == "ATTITUDE":
            with self._lock:
                self._yaw_ned = float(message.yaw)

    def _check_link(self, now: float) -> None:
        if self._connected.is_set() and now - self._heartbeat_at > self._link_timeout:
            self._set_disconnected(f"no heartbeat for {now - self._heartbeat_at:.1f} s")

    def _set_disconnected(self, reason: str) -> None:
        """Records and logs why before `connected` turns false, so whoever sees it false
        also finds the reason."""
        with self._lock:
            if self._connected.is_set():
                self.last_error = reason
                log.warning("%s: vehicle link lost: %s", self.name, reason)
            self._connected.clear()
            self._position = None
            self._yaw_ned = None

    def _send_setpoint(self, conn: Any) -> None:
        waypoint = self.guard.due_next(self._clock())
        vehicle = self._vehicle
        if waypoint is None or vehicle is None or not self._connected.is_set():
            return
        north, east, down = world_to_ned(waypoint[1], waypoint[2], waypoint[3])
        boot_ms = int((time.monotonic() - self._boot) * 1000) & 0xFFFFFFFF
        conn.mav.set_position_target_local_ned_send(
            boot_ms, vehicle[0], vehicle[1], mavlink.MAV_FRAME_LOCAL_NED, POSITION_ONLY,
            north, east, down, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        )
        self.setpoints_sent += 1


class MavlinkUAV:
    """A sensing UAV whose pose comes from a real (or SITL, or simulated) vehicle and
    whose camera is the rendered world: the same follower code as VirtualUAV."""

    def __init__(self, bridge: MavlinkBridge, renderer: Renderer,
                 camera: CameraModel | None = None, world_epoch: float = 0.0) -> None:
        self.bridge = bridge
        self.name = bridge.name
        self.renderer = renderer
        self.camera = camera if camera is not None else CameraModel()
        self.world_epoch = world_epoch

    def set_waypoints(self, waypoints: Sequence[Sequence[float]]) -> bool:
        return self.bridge.set_waypoints(waypoints)

    def capture(self, now: float) -> Frame | None:
        """The frame seen from the vehicle's pose at `now`; None while the link is down."""
        pose = self.bridge.pose_at(now)
        if pose is None or not pose.is_finite() or pose.z <= 0:
            return None
        pixels = self.renderer.frame(pose, self.camera, now - self.world_epoch)
        return Frame(t=now, pose=pose, camera=self.camera, pixels=pixels)
