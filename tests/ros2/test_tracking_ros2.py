"""The tracking demo in ROS 2 (``wiswarm_apps.tracking.ros2``): a third-party client receives
each frame as ``sensor_msgs/msg/Image`` (mono8, the frame's pixels), the UAV's pose as
``geometry_msgs/msg/PoseStamped``, both stamped with the update's generation time on the
leader's clock, and the car the leader's vision tracks as
``visualization_msgs/msg/MarkerArray`` on ``<ns>/cars``, stamped with its estimate's
time; a frame that does not decode is counted, not published."""

from __future__ import annotations

import itertools
import math
from typing import Any

import pytest

from tests.transport.helpers import Recorder, Sessions, eventually
from wiswarm_apps.tracking.frames import Frame, encode_frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.leader_app import VisionLoop
from wiswarm_apps.tracking.reception import Reception
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.ros2 import CarMarkers, FrameAdapter
from wiswarm_apps.tracking.world import World, WorldConfig
from wiswarm_zenoh.core import Delivered, FollowerConfig
from wiswarm_zenoh.ros2 import Ros2Bridge, Ros2Options
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

SWARM = "tracking"
NS = "/wiswarm/tracking"
WORLD = World(WorldConfig(n_cars=1, seed=11, duration_s=60))
CAMERA = CameraModel()
T = 1.0  # when the camera saw the car (the UAV's clock)
CAR = WORLD.car_position(0, T)
POSE = Pose(CAR[0] + 0.2, CAR[1] - 0.1, 2.0, math.pi / 2)
PIXELS = Renderer(WORLD).frame(POSE, CAMERA, T)
FRAME_STEP_S = 0.01  # each poll gets the same view, a step later: the car stands still


def test_frames_poses_and_cars_reach_a_ros2_client(sessions: Sessions, port: int,
                                                   recorder: Recorder,
                                                   open_client: Any) -> None:
    sessions.router(port)
    steps = itertools.count()
    followers = [FollowerNode(sessions.node(port), SWARM, "uav0", FollowerConfig(),
                              sample_on_poll=lambda: encode_frame(Frame(
                                  T + FRAME_STEP_S * next(steps), POSE, CAMERA, PIXELS))),
                 FollowerNode(sessions.node(port), SWARM, "rogue", FollowerConfig(),
                              sample_on_poll=lambda: b"not a frame")]
    vision = VisionLoop({"uav0": 0}, WORLD.arena, camera=CAMERA)  # as the demo's leader
    reception = Reception(["uav0"], vision)

    def on_delivery(event: Delivered) -> None:
        recorder.on_delivery(event)
        reception.on_delivered(event)

    leader = LeaderNode(sessions.node(port), SWARM, bridge=Ros2Options(adapter=FrameAdapter()),
                        on_delivery=on_delivery)
    assert isinstance(leader.bridge, Ros2Bridge)
    vision.start(leader, CarMarkers(leader.bridge))
    try:
        client = open_client(port, 0, [f"{NS}/uav0/image", f"{NS}/uav0/pose", f"{NS}/cars"], [
            (f"{NS}/uav0/image", "sensor_msgs/msg/Image", 1),
            (f"{NS}/uav0/pose", "geometry_msgs/msg/PoseStamped", 1),
            (f"{NS}/rogue/image", "sensor_msgs/msg/Image", 1),
            (f"{NS}/cars", "visualization_msgs/msg/MarkerArray", 1)])
        _, topics = client.next("topics")
        assert [f"{NS}/cars", ["visualization_msgs/msg/MarkerArray"]] in map(list, topics)
        _, _, image = client.next("message", f"{NS}/uav0/image")
        assert (image["height"], image["width"], image["encoding"], image["step"]) == (
            CAMERA.height, CAMERA.width, "mono8", CAMERA.width)
        assert image["data"] == {"len": PIXELS.size, "head": [int(v) for v in PIXELS.flat[:8]]}
        _, _, pose = client.next("message", f"{NS}/uav0/pose")
        position, orientation = pose["pose"]["position"], pose["pose"]["orientation"]
        assert (position["x"], position["y"], position["z"]) == (POSE.x, POSE.y, POSE.z)
        assert 2 * math.atan2(orientation["z"], orientation["w"]) == pytest.approx(math.pi / 2)
        assert pose["header"]["frame_id"] == "world"

        _, _, cars = client.next("message", f"{NS}/cars")
        car, arrow = cars["markers"]
        assert (car["ns"], car["id"], car["type"], car["action"]) == ("cars", 0, 2, 0)  # SPHERE
        where = car["pose"]["position"]
        assert (where["x"], where["y"], where["z"]) == pytest.approx((*CAR, 0.0), abs=0.05)
        assert (arrow["ns"], arrow["id"], arrow["type"]) == ("cars/velocity", 0, 0)  # ARROW
        start, end = arrow["points"]
        assert start == where and (end["x"], end["y"]) == pytest.approx(
            (where["x"], where["y"]), abs=0.05)  # it stands still in every frame
        assert car["header"] == arrow["header"] and car["header"]["frame_id"] == "world"

        generated = {round(d.generated_at * 1e9) for d in recorder.deliveries}
        for message in (image, pose, car):  # a delivery's generation time, leader clock
            stamp = message["header"]["stamp"]
            assert min(abs(stamp["sec"] * 10**9 + stamp["nanosec"] - g)
                       for g in generated) <= 1  # the rounding of one nanosecond
        bad = leader.bridge.bad_input
        eventually("the rogue's updates counted", lambda: bad.counts[
            f"wiswarm/{SWARM}/rogue/update"] >= 1)
    finally:
        vision.stop()
        leader.close()
        for follower in followers:
            follower.close()
