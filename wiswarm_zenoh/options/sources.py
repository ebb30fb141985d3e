"""A follower's source flags (``wiswarm follower --source``, ``--ros2-topic``,
``--ros2-waypoints``, ``--ros-domain``): what the robot already publishes, served
instead of synthetic frames, each source a stream of the robot (``transport.streams``);
refused in one line before anything starts."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from typing import Any

from wiswarm_zenoh.options.arguments import ArgType, integer
from wiswarm_zenoh.ros2.graph import MAX_DOMAIN, check_topic
from wiswarm_zenoh.ros2.topic_source import Ros2TopicSource
from wiswarm_zenoh.transport.source_feed import Source, ZenohSource
from wiswarm_zenoh.transport.streams import Stream, robot_streams, split_name
from wiswarm_zenoh.usage import UsageError


class _Once(argparse.Action):
    """A flag given at most once: argparse keeps the last of several without a word, and
    a follower given two waypoint topics would publish on one of them silently."""

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
    """The flags of a follower's sources and of its waypoints on the robot's ROS 2."""
    follower.add_argument("--source", metavar="[NAME=]KEYEXPR", action="append",
                          type=ArgType("key expression", _named(_key_expr)),
                          help="wiswarm: serve the samples published on this Zenoh key "
                          "expression instead of synthetic frames (each stamped with its "
                          "Zenoh timestamp, else its arrival); repeat it, or mix it with "
                          "--ros2-topic, for several streams of this robot, each a member "
                          "of its own: <id>~NAME (NAME given, or the key with each run of "
                          "other characters than letters, digits and _ made _)")
    follower.add_argument("--ros2-topic", metavar="[NAME=]TOPIC", action="append",
                          type=ArgType("ROS topic", _named(check_topic)),
                          help="wiswarm: serve this ROS 2 topic as rmw_zenoh publishes it "
                          "(any type, found from its publisher; CDR bytes as they came, "
                          "stamped with their source time); a --ros2 leader republishes it "
                          "as <ns>/<id>/<topic>. Repeat it for several topics of this "
                          "robot, each a member of its own, <id>~NAME (NAME given, or the "
                          "topic with / made _: <id>~drone1_camera_image_raw), all on one "
                          "session")
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


def _named(check: Callable[[str], str]) -> Callable[[str], tuple[str | None, str]]:
    """``[NAME=]VALUE``, VALUE checked by ``check``."""
    def parse(text: str) -> tuple[str | None, str]:
        name, value = split_name(text)
        return name, check(value)
    return parse


def _given(args: argparse.Namespace) -> list[tuple[str | None, Source, str]]:
    given: list[tuple[str | None, Source, str]] = []
    for name, key_expr in args.source or ():
        given.append((name, ZenohSource(key_expr), key_expr))
    for name, topic in args.ros2_topic or ():
        given.append((name, Ros2TopicSource(topic, args.ros_domain or 0), topic))
    return given


def _check_source_flags(args: argparse.Namespace) -> None:
    if args.ros_domain is not None and args.ros2_topic is None and args.ros2_waypoints is None:
        raise UsageError("--ros-domain is for --ros2-topic or --ros2-waypoints: add one")
    if (args.source or args.ros2_topic) and args.rate is not None and args.queue != "fifo":
        raise UsageError("--rate paces synthetic frames (or a fifo queue's rate control): "
                         "a source comes at its own rate")


def streams_of(args: argparse.Namespace) -> tuple[Stream, ...]:
    """What the follower serves: a stream per --source and --ros2-topic, or synthetic
    frames (none)."""
    _check_source_flags(args)
    try:
        return robot_streams(args.id, _given(args))
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def one_source(args: argparse.Namespace, why: str) -> Source | None:
    """The one source of a follower that serves one (``why`` it cannot serve more)."""
    _check_source_flags(args)
    given = _given(args)
    if len(given) > 1:
        raise UsageError(f"{why}: give one --source or --ros2-topic")
    if given and given[0][0] is not None:
        raise UsageError(f"{why}: its source is not named (NAME=)")
    return given[0][1] if given else None
