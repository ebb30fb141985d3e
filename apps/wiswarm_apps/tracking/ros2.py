"""The tracking demo in ROS 2: each camera frame as ``sensor_msgs/msg/Image``
(``mono8``) on ``<ns>/<uav>/image`` and the UAV's pose when it took it as
``geometry_msgs/msg/PoseStamped`` (frame ``world``) on ``<ns>/<uav>/pose``, both
stamped with the frame's generation time on the leader's clock; and the cars the
leader tracks as ``visualization_msgs/msg/MarkerArray`` on ``<ns>/cars``, each stamped
with its estimate's time."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from wiswarm_apps.tracking.frames import decode_frame
from wiswarm_apps.tracking.leader_app import CarEstimate
from wiswarm_zenoh.ros2 import (
    IMAGE,
    POSE_STAMPED,
    Output,
    Ros2Bridge,
    header,
    message_class,
    yaw_quaternion,
)

WORLD_FRAME = "world"
CARS = "cars"  # the topic <ns>/cars
MARKER = "visualization_msgs/msg/Marker"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
CAR_SIZE_M = 0.2
AHEAD_S = 1.0  # the velocity arrow ends where the car will be this much later
ARROW_SCALE = (0.04, 0.08, 0.08)  # shaft diameter, head diameter, head length (m)
CAR_COLOUR = (1.0, 0.4, 0.1, 1.0)


def _point(x: float, y: float, z: float) -> Any:
    return message_class("geometry_msgs/msg/Point")(x=x, y=y, z=z)


class FrameAdapter:
    """A tracking frame to an image and a pose (a malformed frame: FrameError)."""

    outputs = (Output("image", IMAGE), Output("pose", POSE_STAMPED))

    def messages(self, follower: str, update: bytes, generated_at: float) -> Sequence[Any]:
        frame = decode_frame(update)
        height, width = frame.pixels.shape
        image = message_class(IMAGE)(
            header=header(generated_at, f"{follower}/camera"), height=height, width=width,
            encoding="mono8", is_bigendian=0, step=width, data=frame.pixels.reshape(-1))
        pose = message_class("geometry_msgs/msg/Pose")(
            position=_point(frame.pose.x, frame.pose.y, frame.pose.z),
            orientation=yaw_quaternion(frame.pose.yaw))
        return [image, message_class(POSE_STAMPED)(header=header(generated_at, WORLD_FRAME),
                                                   pose=pose)]


class CarMarkers:
    """Publishes each new car estimate of the leader's vision (``VisionLoop``'s
    ``on_estimate``) on the leader's ROS 2 node, ``<ns>/cars``."""

    def __init__(self, bridge: Ros2Bridge) -> None:
        self._publisher = bridge.publisher(f"{bridge.namespace}/{CARS}", MARKER_ARRAY)

    def __call__(self, estimate: CarEstimate) -> None:
        if self._publisher.listening:  # else not even built
            self._publisher.publish(car_markers(estimate))


def car_markers(estimate: CarEstimate) -> Any:
    """The car as a sphere where the leader estimates it (namespace ``cars``) and an
    arrow from there to where it will be ``AHEAD_S`` later (``cars/velocity``), both
    with the car's marker id as id, stamped with the estimate's time in the frame
    ``world``; kept by a viewer until the next estimate replaces them, as the leader's
    last plan stands while the car is out of view."""
    marker = message_class(MARKER)
    (x, y), (vx, vy) = estimate.xy, estimate.velocity
    here = _point(x, y, 0.0)
    ahead = _point(x + vx * AHEAD_S, y + vy * AHEAD_S, 0.0)
    return message_class(MARKER_ARRAY)(markers=[
        _marker(estimate, CARS, marker.SPHERE, here, (CAR_SIZE_M,) * 3, []),
        _marker(estimate, f"{CARS}/velocity", marker.ARROW, _point(0.0, 0.0, 0.0),
                ARROW_SCALE, [here, ahead])])


def _marker(estimate: CarEstimate, ns: str, kind: int, position: Any,
            scale: tuple[float, ...], points: list[Any]) -> Any:
    """A marker of ``kind`` that adds (or replaces) ``ns``/the car's id, forever; the
    fields for meshes and textures empty."""
    marker = message_class(MARKER)
    nothing = np.empty(0, np.uint8)
    r, g, b, a = CAR_COLOUR
    return marker(
        header=header(estimate.at, WORLD_FRAME), ns=ns, id=estimate.car, type=kind,
        action=marker.ADD,
        pose=message_class("geometry_msgs/msg/Pose")(position=position,
                                                     orientation=yaw_quaternion(0.0)),
        scale=message_class("geometry_msgs/msg/Vector3")(x=scale[0], y=scale[1], z=scale[2]),
        color=message_class("std_msgs/msg/ColorRGBA")(r=r, g=g, b=b, a=a),
        lifetime=message_class("builtin_interfaces/msg/Duration")(sec=0, nanosec=0),
        frame_locked=False, points=points, colors=[], texture_resource="",
        texture=message_class("sensor_msgs/msg/CompressedImage")(
            header=header(0.0), format="", data=nothing),
        uv_coordinates=[], text="", mesh_resource="",
        mesh_file=message_class("visualization_msgs/msg/MeshFile")(filename="", data=nothing),
        mesh_use_embedded_materials=False)

