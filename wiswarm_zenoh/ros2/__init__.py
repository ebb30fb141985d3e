"""ROS 2 over rmw_zenoh (its design document): the leader as a ROS 2 participant, and
the pieces an application needs to map its updates to standard messages."""

from wiswarm_zenoh.ros2.adapters import (
    BytesAdapter,
    Output,
    UpdateAdapter,
    adapter,
    adapter_names,
    register_adapter,
)
from wiswarm_zenoh.ros2.bridge import Ros2Bridge, Ros2Options, default_namespace
from wiswarm_zenoh.ros2.messages import (
    IMAGE,
    PATH,
    POSE_STAMPED,
    header,
    message_class,
    ros_type,
    yaw_quaternion,
)

__all__ = [
    "IMAGE",
    "PATH",
    "POSE_STAMPED",
    "BytesAdapter",
    "Output",
    "Ros2Bridge",
    "Ros2Options",
    "UpdateAdapter",
    "adapter",
    "adapter_names",
    "default_namespace",
    "header",
    "message_class",
    "register_adapter",
    "ros_type",
    "yaw_quaternion",
]
