"""ROS 2 over rmw_zenoh (its design document): the leader as a ROS 2 participant, and
the pieces an application needs to map its updates to standard messages."""

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
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

# Loaded when first named (PEP 562): the message types (rosbags) cost a node that never
# speaks ROS 2 tens of MB, and a submodule (``graph``) is imported without them.
_HOMES = {
    **dict.fromkeys(("BytesAdapter", "Output", "UpdateAdapter", "adapter", "adapter_names",
                     "register_adapter"), "adapters"),
    **dict.fromkeys(("Ros2Bridge", "Ros2Options", "default_namespace"), "bridge"),
    **dict.fromkeys(("IMAGE", "PATH", "POSE_STAMPED", "header", "message_class", "ros_type",
                     "yaw_quaternion"), "messages"),
}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{home}"), name)


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
