"""The tracking demo's updates in ROS 2: each camera frame as ``sensor_msgs/msg/Image``
(``mono8``) on ``<ns>/<uav>/image`` and the UAV's pose when it took it as
``geometry_msgs/msg/PoseStamped`` (frame ``world``) on ``<ns>/<uav>/pose``, both
stamped with the frame's generation time on the leader's clock."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from apps.tracking.frames import decode_frame
from wiswarm_zenoh.ros2 import (
    IMAGE,
    POSE_STAMPED,
    Output,
    header,
    message_class,
    register_adapter,
    yaw_quaternion,
)

WORLD_FRAME = "world"


class FrameAdapter:
    """A tracking frame to an image and a pose (a malformed frame: FrameError)."""

    outputs = (Output("image", IMAGE), Output("pose", POSE_STAMPED))

    def messages(self, follower: str, update: bytes, generated_at: float) -> Sequence[Any]:
        frame = decode_frame(update)
        height, width = frame.pixels.shape
        image = message_class(IMAGE)(
            header=header(generated_at, f"{follower}/camera"), height=height, width=width,
            encoding="mono8", is_bigendian=0, step=width, data=frame.pixels.reshape(-1))
        point = message_class("geometry_msgs/msg/Point")(x=frame.pose.x, y=frame.pose.y,
                                                         z=frame.pose.z)
        pose = message_class("geometry_msgs/msg/Pose")(
            position=point, orientation=yaw_quaternion(frame.pose.yaw))
        return [image, message_class(POSE_STAMPED)(header=header(generated_at, WORLD_FRAME),
                                                   pose=pose)]


register_adapter("tracking", FrameAdapter())
