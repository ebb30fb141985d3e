"""The tracking demo's frames in ROS 2 (``apps.tracking.ros2``): a third-party client
receives each as ``sensor_msgs/msg/Image`` (mono8, the frame's pixels) and the UAV's
pose as ``geometry_msgs/msg/PoseStamped``, both stamped with the update's generation
time on the leader's clock; a frame that does not decode is counted, not published."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from apps.tracking.frames import Frame, encode_frame
from apps.tracking.geometry import CameraModel, Pose
from apps.tracking.ros2 import FrameAdapter
from tests.transport.helpers import Recorder, Sessions, eventually
from wiswarm_zenoh.core import FollowerConfig
from wiswarm_zenoh.ros2 import Ros2Options
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

SWARM = "tracking"
NS = "/wiswarm/tracking"
CAMERA = CameraModel(width=32, height=24)
PIXELS = (np.arange(CAMERA.width * CAMERA.height) % 251).astype(np.uint8).reshape(24, 32)
POSE = Pose(1.5, 2.5, 2.0, math.pi / 2)


def test_frames_and_poses_reach_a_ros2_client(sessions: Sessions, port: int,
                                              recorder: Recorder, open_client: Any) -> None:
    sessions.router(port)
    frame = encode_frame(Frame(t=0.0, pose=POSE, camera=CAMERA, pixels=PIXELS))
    followers = [FollowerNode(sessions.node(port), SWARM, "uav0", FollowerConfig(),
                              sample_on_poll=lambda: frame),
                 FollowerNode(sessions.node(port), SWARM, "rogue", FollowerConfig(),
                              sample_on_poll=lambda: b"not a frame")]
    leader = LeaderNode(sessions.node(port), SWARM, bridge=Ros2Options(adapter=FrameAdapter()),
                        **recorder.callbacks())
    try:
        client = open_client(port, 0, [f"{NS}/uav0/image", f"{NS}/uav0/pose"], [
            (f"{NS}/uav0/image", "sensor_msgs/msg/Image", 1),
            (f"{NS}/uav0/pose", "geometry_msgs/msg/PoseStamped", 1),
            (f"{NS}/rogue/image", "sensor_msgs/msg/Image", 1)])
        _, _, image = client.next("message", f"{NS}/uav0/image")
        assert (image["height"], image["width"], image["encoding"], image["step"]) == (
            24, 32, "mono8", 32)
        assert image["data"] == {"len": PIXELS.size, "head": [int(v) for v in PIXELS.flat[:8]]}
        _, _, pose = client.next("message", f"{NS}/uav0/pose")
        position, orientation = pose["pose"]["position"], pose["pose"]["orientation"]
        assert (position["x"], position["y"], position["z"]) == (1.5, 2.5, 2.0)
        assert 2 * math.atan2(orientation["z"], orientation["w"]) == pytest.approx(math.pi / 2)
        assert pose["header"]["frame_id"] == "world"
        generated = {round(d.generated_at * 1e9) for d in recorder.deliveries}
        for message in (image, pose):
            stamp = message["header"]["stamp"]
            assert min(abs(stamp["sec"] * 10**9 + stamp["nanosec"] - g)
                       for g in generated) <= 1  # the rounding of one nanosecond
        bad = leader.bridge.bad_input  # type: ignore[union-attr]
        eventually("the rogue's updates counted", lambda: bad.counts[
            f"wiswarm/{SWARM}/rogue/update"] >= 1)
    finally:
        leader.close()
        for follower in followers:
            follower.close()
