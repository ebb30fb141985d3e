"""A ROS 2 participant nobody here wrote: ``zenoh-ros2-sdk`` (PyPI), in a ``spawn``
child, scripted over a pipe. It lists the graph, subscribes, and sends back the first
message of each topic as plain data; it publishes what the test asks."""

from __future__ import annotations

import math
import os
import time
from dataclasses import fields, is_dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

LIST_TIMEOUT_S = 15.0


def plain(value: Any) -> Any:
    """A decoded message as dicts, lists and numbers (arrays: their length and head)."""
    if is_dataclass(value):
        return {f.name: plain(getattr(value, f.name)) for f in fields(value)
                if not f.name.startswith("__")}
    if hasattr(value, "dtype"):
        return {"len": int(value.size), "head": [int(v) for v in value.reshape(-1)[:8]]}
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


def run_client(port: int, domain: int, definitions: Path, expected: list[str],
               subscribe: list[tuple[str, str, int]], pipe: Connection) -> None:
    """Until the pipe says "stop": ("topics", [(name, types)]) once ``expected`` all show,
    ("info", topic info of ``expected[0]`` with its endpoints' nodes),
    ("message", topic, plain message) for the first ``count`` messages of each
    subscribed ``(topic, type, count)``,
    and for ("publish", topic, type, poses) a Path (or String) published, then ("sent",)."""
    os.environ["ZENOH_CONFIG_OVERRIDE"] = (
        'scouting/multicast/enabled=false;listen/endpoints=["tcp/127.0.0.1:0"]')
    from zenoh_ros2_sdk import (
        ROS2Publisher,
        ROS2Subscriber,
        get_message_class,
        get_registry,
        get_topic_info,
        get_topic_names_and_types,
    )

    get_registry().messages_dir = definitions
    deadline = time.monotonic() + LIST_TIMEOUT_S
    while True:
        topics = get_topic_names_and_types(domain, router_port=port, timeout=0.5)
        names = {name for name, _ in topics}
        if set(expected) <= names or time.monotonic() > deadline:
            break
    pipe.send(("topics", topics))
    while (info := get_topic_info(expected[0], domain, router_port=port, verbose=True)) is None:
        if time.monotonic() > deadline:  # a liveliness query may come back short: ask again
            break
    pipe.send(("info", plain(info)))
    seen: dict[str, int] = {}

    def first(topic: str, count: int) -> Any:
        def on_message(message: Any) -> None:
            if seen.setdefault(topic, 0) < count:
                seen[topic] += 1
                pipe.send(("message", topic, plain(message)))
        return on_message

    entities: list[Any] = [ROS2Subscriber(topic, kind, first(topic, count), domain_id=domain,
                                          router_port=port)
                           for topic, kind, count in subscribe]
    publishers: dict[tuple[str, str], Any] = {}
    while (command := pipe.recv())[0] != "stop":
        _, topic, kind, poses = command
        if (topic, kind) not in publishers:
            publishers[topic, kind] = ROS2Publisher(topic, kind, domain_id=domain,
                                                     router_port=port)
            entities.append(publishers[topic, kind])
            matched(publishers[topic, kind].pub)
        if kind == "std_msgs/msg/String":
            publishers[topic, kind].publish(data="not a path")
        else:
            publishers[topic, kind].publish(**path_fields(get_message_class, poses))
        pipe.send(("sent",))
    for entity in entities:
        entity.close()


def matched(publisher: Any) -> None:
    """Until the leader's subscription is known to ``publisher`` (a put before reaches
    nobody)."""
    import threading

    import zenoh

    known = threading.Event()
    listener = publisher.declare_matching_listener(zenoh.handlers.Callback(
        lambda status: status.matching and known.set(), indirect=False))
    if publisher.matching_status.matching:
        known.set()
    known.wait(LIST_TIMEOUT_S)
    listener.undeclare()


def path_fields(message_class: Any, poses: list[tuple[float, float, float, float]]) -> Any:
    """A Path's fields: each (t, x, y, z) a pose stamped t."""
    time_, header, point, quaternion, pose, stamped = (message_class(name) for name in (
        "builtin_interfaces/msg/Time", "std_msgs/msg/Header", "geometry_msgs/msg/Point",
        "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Pose",
        "geometry_msgs/msg/PoseStamped"))

    def head(t: float) -> Any:
        sec = math.floor(t) if math.isfinite(t) else 0
        return header(stamp=time_(sec=sec, nanosec=int((t - sec) * 1e9) if math.isfinite(t)
                                  else 0), frame_id="world")

    return {"header": head(poses[0][0] if poses else 0.0), "poses": [
        stamped(header=head(t), pose=pose(position=point(x=x, y=y, z=z),
                                          orientation=quaternion(x=0.0, y=0.0, z=0.0, w=1.0)))
        for t, x, y, z in poses]}
