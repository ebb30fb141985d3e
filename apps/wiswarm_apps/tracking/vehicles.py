"""The flying part of a UAV process, behind one face: a virtual UAV, or a MAVLink vehicle
(here the simulated one on UDP loopback, standing in for SITL or an autopilot) whose
pose stamps the frames and which receives the waypoints as position setpoints."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

from wiswarm_apps.tracking.frames import Frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose, world_to_ned, yaw_to_ned
from wiswarm_apps.tracking.kinds import VEHICLE_KINDS, VehicleKind
from wiswarm_apps.tracking.mavlink_link import MavlinkBridge, MavlinkUAV
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.sim_vehicle import SimVehicle
from wiswarm_apps.tracking.uav import VirtualUAV
from wiswarm_apps.tracking.waypoints import WaypointGuard

CONNECT_TIMEOUT_S = 10.0


@dataclass(frozen=True)
class Vehicle:
    """What the UAV process needs: frames, the pose at a time, and the waypoint guard
    (the last safe plan). `capture`/`pose_at` give None while a MAVLink link is down."""

    capture: Callable[[float], Frame | None]
    pose_at: Callable[[float], Pose | None]
    guard: WaypointGuard

    def set_waypoints(self, waypoints: Sequence[Sequence[float]]) -> bool:
        return self.guard.offer(waypoints)


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


@contextmanager
def open_vehicle(kind: VehicleKind, name: str, start: Pose, renderer: Renderer,
                 camera: CameraModel, world_epoch: float,
                 max_speed_mps: float) -> Iterator[Vehicle]:
    """The vehicle, flying from `start` now; a MAVLink one is stopped on exit."""
    if kind == "virtual":
        virtual = VirtualUAV(name, start, renderer, time.time(), camera, max_speed_mps,
                             world_epoch)
        yield Vehicle(virtual.capture, virtual.pose, virtual.guard)
        return
    if kind != "mavlink-sim":
        raise ValueError(f"vehicle must be one of {VEHICLE_KINDS}, got {kind!r}")
    port = _free_udp_port()
    bridge = MavlinkBridge(f"udpin:127.0.0.1:{port}", renderer.world.arena, name)
    sim = SimVehicle(f"udpout:127.0.0.1:{port}", start_ned=world_to_ned(start.x, start.y, start.z),
                     yaw_ned=yaw_to_ned(start.yaw), max_speed_mps=max_speed_mps)
    bridge.start()
    sim.start()
    try:
        if not bridge.wait_connected(CONNECT_TIMEOUT_S):
            raise RuntimeError(f"{name}: the simulated vehicle did not connect")
        uav = MavlinkUAV(bridge, renderer, camera, world_epoch)
        yield Vehicle(uav.capture, bridge.pose_at, bridge.guard)
    finally:
        sim.stop()
        bridge.stop()
