"""A small simulated vehicle speaking MAVLink over UDP, standing in for SITL or a real
autopilot in tests and demos: heartbeat (1 Hz by default), LOCAL_POSITION_NED and ATTITUDE at
`rate_hz`, and it flies to the latest SET_POSITION_TARGET_LOCAL_NED at bounded speed.
It works in NED, like an autopilot; yaw is held.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from typing import Any

from pymavlink import mavutil

log = logging.getLogger(__name__)
mavlink = mavutil.mavlink
POSITION_IGNORED = (
    mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE
)


class SimVehicle:
    """Run with `start()` (a daemon thread) and end with `stop()`."""

    def __init__(self, connection: str, start_ned: tuple[float, float, float] = (0.0, 0.0, -2.0),
                 yaw_ned: float = 0.0, max_speed_mps: float = 2.0, rate_hz: float = 30.0,
                 heartbeat_hz: float = 1.0, system_id: int = 1, component_id: int = 1) -> None:
        if not (math.isfinite(max_speed_mps) and max_speed_mps > 0):
            raise ValueError(f"max_speed_mps must be positive, got {max_speed_mps!r}")
        if not 1 <= rate_hz <= 1000:
            raise ValueError(f"rate_hz must be in [1, 1000], got {rate_hz!r}")
        if not 0.1 <= heartbeat_hz <= rate_hz:
            raise ValueError(f"heartbeat_hz must be in [0.1, rate_hz], got {heartbeat_hz!r}")
        self.connection = connection
        self.system_id = system_id
        self.component_id = component_id
        self.max_speed_mps = max_speed_mps
        self.yaw_ned = yaw_ned
        self.setpoints_received = 0
        self.setpoints_ignored = 0
        self.setpoint_arrived = threading.Event()
        self._period = 1.0 / rate_hz
        self._heartbeat_period = 1.0 / heartbeat_hz
        self._position = start_ned
        self._target: tuple[float, float, float] | None = None
        self._velocity = (0.0, 0.0, 0.0)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._boot = time.monotonic()

    @property
    def position_ned(self) -> tuple[float, float, float]:
        with self._lock:
            return self._position

    @property
    def target_ned(self) -> tuple[float, float, float] | None:
        with self._lock:
            return self._target

    def start(self) -> None:
        if self._thread is not None:
            raise RuntimeError("vehicle already started")
        conn = mavutil.mavlink_connection(
            self.connection, source_system=self.system_id, source_component=self.component_id
        )
        self._thread = threading.Thread(
            target=self._run, args=(conn,), name="sim-vehicle", daemon=True
        )
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    def _run(self, conn: Any) -> None:
        last = time.monotonic()
        next_heartbeat = last
        try:
            while not self._stop.is_set():
                message = conn.recv_match(blocking=False)
                while message is not None:
                    self._handle(message)
                    message = conn.recv_match(blocking=False)
                now = time.monotonic()
                self._fly(now - last)
                last = now
                if now >= next_heartbeat:
                    conn.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR,
                                            mavlink.MAV_AUTOPILOT_GENERIC, 0, 0,
                                            mavlink.MAV_STATE_ACTIVE)
                    next_heartbeat = now + self._heartbeat_period
                self._report(conn, now)
                self._stop.wait(self._period)
        except Exception:  # a simulator must say why it died, then end quietly
            log.exception("simulated vehicle stopped on an error")
        finally:
            conn.close()

    def _handle(self, message: Any) -> None:
        if message.get_type() != "SET_POSITION_TARGET_LOCAL_NED":
            return
        if message.target_system not in (0, self.system_id):
            return
        if (message.coordinate_frame != mavlink.MAV_FRAME_LOCAL_NED
                or message.type_mask & POSITION_IGNORED):
            self.setpoints_ignored += 1
            return
        target = (float(message.x), float(message.y), float(message.z))
        if not all(math.isfinite(value) for value in target):
            self.setpoints_ignored += 1
            return
        with self._lock:
            self._target = target
        self.setpoints_received += 1
        self.setpoint_arrived.set()

    def _fly(self, dt: float) -> None:
        with self._lock:
            target, position = self._target, self._position
            if target is None or dt <= 0:
                self._velocity = (0.0, 0.0, 0.0)
                return
            delta = [t - p for t, p in zip(target, position, strict=True)]
            distance = math.sqrt(sum(d * d for d in delta))
            step = min(distance, self.max_speed_mps * dt)
            scale = step / distance if distance > 1e-12 else 0.0
            self._position = (position[0] + scale * delta[0], position[1] + scale * delta[1],
                              position[2] + scale * delta[2])
            self._velocity = (scale * delta[0] / dt, scale * delta[1] / dt, scale * delta[2] / dt)

    def _report(self, conn: Any, now: float) -> None:
        with self._lock:
            (n, e, d), (vn, ve, vd) = self._position, self._velocity
        boot_ms = int((now - self._boot) * 1000) & 0xFFFFFFFF
        conn.mav.local_position_ned_send(boot_ms, n, e, d, vn, ve, vd)
        conn.mav.attitude_send(boot_ms, 0.0, 0.0, self.yaw_ned, 0.0, 0.0, 0.0)
