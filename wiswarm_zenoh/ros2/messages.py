"""ROS 2 message types through ``rosbags``: CDR bytes, RIHS01 type hashes and the DDS
type names that rmw_zenoh puts in its keys, from one store of the standard messages
(Jazzy's), so no encoder or hash is written by hand here. The store (rosbags: the ros2
extra, tens of MB) is loaded when a type is first used, not when this module is."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import Any

from wiswarm_zenoh.extras import require

NS_PER_S = 1_000_000_000

UPDATE_BYTES = "std_msgs/msg/UInt8MultiArray"
IMAGE = "sensor_msgs/msg/Image"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
PATH = "nav_msgs/msg/Path"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"


class MessageError(ValueError):
    """Bytes that are not a CDR message of the type expected (the message says why)."""


@dataclass(frozen=True)
class RosType:
    """A message type as rmw_zenoh names it: ``pkg/msg/Name``, its DDS name
    (``pkg::msg::dds_::Name_``) and its RIHS01 hash."""

    name: str
    dds_name: str
    hash: str


@cache
def _store() -> Any:
    """The standard messages' store; MissingExtra without the ros2 extra."""
    require("ros2")
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


@cache
def ros_type(name: str) -> RosType:
    """The type ``name`` (``pkg/msg/Name``); ValueError for a type the store lacks."""
    if name not in _store().types:
        raise ValueError(f"unknown ROS 2 message type {name!r}")
    pkg, kind, short = name.split("/")
    return RosType(name, f"{pkg}::{kind}::dds_::{short}_", _store().hash_rihs01(name))


def message_class(name: str) -> Any:
    """The class of ``name``'s messages (a dataclass; fields as in the .msg file)."""
    ros_type(name)
    return _store().types[name]


def serialize(message: Any, name: str) -> bytes:
    """CDR bytes (with their encapsulation header) of ``message``, of type ``name``."""
    return bytes(_store().serialize_cdr(message, name))


def deserialize(data: bytes, name: str) -> Any:
    """The message of type ``name`` in ``data``; MessageError for anything else."""
    store = _store()
    try:
        return store.deserialize_cdr(data, name)
    except Exception as exc:  # rosbags raises several types on truncated or odd bytes
        raise MessageError(f"not a CDR {name}: {exc}") from None


def stamp(seconds: float) -> Any:
    """A ``builtin_interfaces/msg/Time`` for ``seconds`` since the epoch."""
    ns = round(seconds * NS_PER_S)
    return message_class("builtin_interfaces/msg/Time")(sec=ns // NS_PER_S,
                                                        nanosec=ns % NS_PER_S)


def seconds(time: Any) -> float:
    """A ``builtin_interfaces/msg/Time`` as seconds since the epoch."""
    return float(time.sec) + float(time.nanosec) / NS_PER_S


def header(at: float, frame_id: str = "") -> Any:
    """A ``std_msgs/msg/Header`` stamped ``at`` (seconds since the epoch)."""
    return message_class("std_msgs/msg/Header")(stamp=stamp(at), frame_id=frame_id)


def yaw_quaternion(yaw: float) -> Any:
    """A ``geometry_msgs/msg/Quaternion`` turning by ``yaw`` radians about z."""
    return message_class("geometry_msgs/msg/Quaternion")(
        x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
