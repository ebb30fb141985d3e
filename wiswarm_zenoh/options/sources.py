"""A follower's source flags (``wiswarm follower --source``, ``--ros2-topic``,
``--ros2-waypoints``, ``--ros-domain``): what the robot already publishes, served
instead of synthetic frames; refused in one line before anything starts."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from wiswarm_zenoh.options.arguments import ArgType, integer
from wiswarm_zenoh.ros2.graph import MAX_DOMAIN, check_topic
from wiswarm_zenoh.ros2.topic_source import Ros2TopicSource
from wiswarm_zenoh.transport.source_feed import ZenohSource
from wiswarm_zenoh.usage import UsageError


class _Once(argparse.Action):
    """A flag given at most once: argparse keeps the last of several without a word, and
    a follower given two topics would serve one of them silently."""

    def __init__(self, *args: Any, why: str, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.why = why

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: str | Sequence[Any] | None, option_string: str | None = None) -> None:
        given = getattr(namespace, self.dest, None)
        if given is not None:
            raise argparse.ArgumentError(None, f"{self.option_strings[0]} given twice "
                                         f"({given}, {values}): {self.why}")
        setattr(namespace, self.dest, values)


def add_source_arguments(follower: argparse.ArgumentParser) -> None:
    """The flags of a follower's source and of its waypoints on the robot's ROS 2."""
    follower.add_argument("--source", metavar="KEYEXPR", type=ArgType("key expression",
                                                                      _key_expr),
                          action=_Once, why="one follower serves one source; run a "
                          "follower per source",
                          help="wiswarm: serve the samples published on this Zenoh key "
                          "expression instead of synthetic frames (each stamped with its "
                          "Zenoh timestamp, else its arrival); one per follower")
    follower.add_argument("--ros2-topic", metavar="TOPIC", type=ArgType("ROS topic",
                                                                        check_topic),
                          action=_Once, why="one follower serves one topic; run a "
                          "follower per topic",
                          help="wiswarm: serve this ROS 2 topic as rmw_zenoh publishes it "
                          "(any type, found from its publisher; CDR bytes as they came, "
                          "stamped with their source time); a --ros2 leader republishes it "
                          "as <ns>/<follower>/<topic>; one per follower")
    follower.add_argument("--ros2-waypoints", metavar="TOPIC", type=ArgType("ROS topic",
                                                                            check_topic),
                          action=_Once, why="a follower publishes its waypoints on one "
                          "topic",
                          help="wiswarm: publish this follower's waypoints as a "
                          "nav_msgs/msg/Path on TOPIC of the robot's ROS 2 (the ros2 extra)")
    follower.add_argument("--ros-domain", type=integer(0, MAX_DOMAIN), metavar="D",
                          help="the ROS domain of --ros2-topic and --ros2-waypoints "
                          "(ROS_DOMAIN_ID; default 0)")


def _key_expr(text: str) -> str:
    return ZenohSource(text).key_expr  # ValueError saying why not


def source_of(args: argparse.Namespace) -> ZenohSource | Ros2TopicSource | None:
    """What the follower serves: --source, --ros2-topic, or synthetic frames (None)."""
    if args.source is not None and args.ros2_topic is not None:
        raise UsageError("give --source or --ros2-topic, not both")
    if args.ros_domain is not None and args.ros2_topic is None and args.ros2_waypoints is None:
        raise UsageError("--ros-domain is for --ros2-topic or --ros2-waypoints: add one")
    if (args.source or args.ros2_topic) and args.rate is not None and args.queue != "fifo":
        raise UsageError("--rate paces synthetic frames (or a fifo queue's rate control): "
                         "a source comes at its own rate")
    if args.source is not None:
        return ZenohSource(args.source)
    if args.ros2_topic is not None:
        return Ros2TopicSource(args.ros2_topic, args.ros_domain or 0)
    return None


