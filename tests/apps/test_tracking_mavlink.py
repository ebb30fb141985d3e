"""The MAVLink bridge against the simulated vehicle over real UDP on loopback."""

from __future__ import annotations

import logging
import math
import socket
import time
from collections.abc import Callable, Iterator

import pytest

from wiswarm_apps.tracking import mavlink_link
from wiswarm_apps.tracking.geometry import Arena, CameraModel, world_to_ned
from wiswarm_apps.tracking.mavlink_link import MavlinkBridge, MavlinkUAV
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.sim_vehicle import SimVehicle
from wiswarm_apps.tracking.world import World, WorldConfig

TIMEOUT = 5.0


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


@pytest.fixture
def port() -> int:
    return free_udp_port()


@pytest.fixture
def bridge(port: int) -> Iterator[MavlinkBridge]:
    link = MavlinkBridge(f"udpin:127.0.0.1:{port}", Arena(), name="uav-3",
                         link_timeout_s=0.6, reconnect_delay_s=0.05)
    link.start()
    yield link
    link.stop()


class SlowHandler(logging.Handler):
    """Holds each record a while before the root logger's handlers see it."""

    def emit(self, record: logging.LogRecord) -> None:
        time.sleep(0.3)


def vehicle_at(port: int, x: float, y: float, z: float, yaw_ned: float = 0.0) -> SimVehicle:
    vehicle = SimVehicle(f"udpout:127.0.0.1:{port}", start_ned=world_to_ned(x, y, z),
                         yaw_ned=yaw_ned, max_speed_mps=3.0, heartbeat_hz=10.0)
    vehicle.start()
    return vehicle


def test_pose_stamps_frames_in_world_coordinates(
    port: int, bridge: MavlinkBridge, wait: Callable[..., bool],
) -> None:
    vehicle = vehicle_at(port, 4.0, 3.0, 2.0, yaw_ned=math.pi / 2)  # facing east
    try:
        assert bridge.wait_connected(TIMEOUT)
        assert wait(lambda: bridge.pose_at(time.time()) is not None)
        pose = bridge.pose_at(time.time())
        assert pose is not None
        assert (pose.x, pose.y, pose.z) == pytest.approx((4.0, 3.0, 2.0), abs=1e-5)
        assert pose.yaw == pytest.approx(0.0, abs=1e-6)  # east is world yaw 0
        world = World(WorldConfig(seed=1, duration_s=10))
        uav = MavlinkUAV(bridge, Renderer(world), CameraModel(width=160, height=160))
        frame = uav.capture(time.time())
        assert frame is not None and frame.pixels.shape == (160, 160)
        assert (frame.pose.x, frame.pose.y) == pytest.approx((4.0, 3.0), abs=1e-5)
    finally:
        vehicle.stop()


def test_waypoints_arrive_as_setpoints_and_the_vehicle_flies_there(
    port: int, bridge: MavlinkBridge, wait: Callable[..., bool],
) -> None:
    vehicle = vehicle_at(port, 4.0, 3.0, 2.0)
    try:
        assert bridge.wait_connected(TIMEOUT)
        now = time.time()
        assert bridge.set_waypoints([(now + 0.5, 5.0, 3.5, 2.5), (now + 60, 5.5, 3.5, 2.5)])
        assert vehicle.setpoint_arrived.wait(TIMEOUT)
        assert vehicle.target_ned == pytest.approx(world_to_ned(5.0, 3.5, 2.5))
        # once the first waypoint is due, the next one is streamed
        assert wait(lambda: vehicle.target_ned == pytest.approx(world_to_ned(5.5, 3.5, 2.5)))

        def arrived() -> bool:
            pose = bridge.pose_at(time.time())
            return pose is not None and math.dist((pose.x, pose.y, pose.z), (5.5, 3.5, 2.5)) < 0.01

        assert wait(arrived)
        assert bridge.setpoints_sent >= vehicle.setpoints_received >= 2
    finally:
        vehicle.stop()


def test_bad_waypoints_are_refused_and_the_vehicle_holds(
    port: int, bridge: MavlinkBridge, caplog: pytest.LogCaptureFixture, wait: Callable[..., bool],
) -> None:
    vehicle = vehicle_at(port, 4.0, 3.0, 2.0)
    try:
        assert bridge.wait_connected(TIMEOUT)
        assert bridge.set_waypoints([(time.time(), 4.5, 3.0, 2.0)])
        assert vehicle.setpoint_arrived.wait(TIMEOUT)
        with caplog.at_level(logging.WARNING):
            assert not bridge.set_waypoints([(time.time() + 1, math.nan, 3.0, 2.0)])
            assert not bridge.set_waypoints([(time.time() + 1, 4.0, 12.0, 2.0)])
        assert "not finite" in caplog.text and "outside" in caplog.text
        received = vehicle.setpoints_received
        assert wait(lambda: vehicle.setpoints_received >= received + 3)
        assert vehicle.target_ned == pytest.approx(world_to_ned(4.5, 3.0, 2.0))
    finally:
        vehicle.stop()


def test_link_drop_is_reported_and_the_link_recovers(
    port: int, bridge: MavlinkBridge, caplog: pytest.LogCaptureFixture, wait: Callable[..., bool],
) -> None:
    vehicle = vehicle_at(port, 4.0, 3.0, 2.0)
    assert bridge.wait_connected(TIMEOUT)
    assert wait(lambda: bridge.pose_at(time.time()) is not None)
    uav = MavlinkUAV(bridge, Renderer(World(WorldConfig(seed=1, duration_s=10))))
    slow = SlowHandler()  # a preempted link thread: whoever sees the link down finds why
    logging.getLogger(mavlink_link.__name__).addHandler(slow)
    try:
        with caplog.at_level(logging.WARNING):
            vehicle.stop()
            assert wait(lambda: not bridge.connected)
        assert "link lost: no heartbeat" in caplog.text
        assert bridge.last_error is not None and bridge.last_error.startswith("no heartbeat")
    finally:
        logging.getLogger(mavlink_link.__name__).removeHandler(slow)
    assert bridge.pose_at(time.time()) is None
    assert uav.capture(time.time()) is None  # no pose, no frame; nothing raises
    again = vehicle_at(port, 6.0, 3.0, 2.0)
    try:
        assert bridge.wait_connected(TIMEOUT)
        assert wait(lambda: (pose := bridge.pose_at(time.time())) is not None
                        and pose.x == pytest.approx(6.0, abs=1e-5))
    finally:
        again.stop()


def test_unusable_connection_string_fails_at_start() -> None:
    with pytest.raises(ValueError, match="host:port"):
        MavlinkBridge("udpin:127.0.0.1", Arena()).start()
