"""The ROS 2 flags of a leader (``wiswarm leader``, ``wiswarm demo``): ``--ros2`` and
what it takes, refused in one line before anything starts."""

from __future__ import annotations

import argparse

from wiswarm_zenoh.extras import require
from wiswarm_zenoh.options.arguments import ArgType, integer, positive_float
from wiswarm_zenoh.ros2 import Ros2Options, adapter
from wiswarm_zenoh.ros2.graph import MAX_DOMAIN, check_namespace
from wiswarm_zenoh.usage import UsageError


def _adapter_name(text: str) -> str:
    adapter(text)  # ValueError naming the registered ones
    return text


UPDATE_ADAPTER = ArgType("choice", _adapter_name)  # by name, as the application registered it


LEADER_HELP = ("also be a ROS 2 participant over rmw_zenoh: each delivered "
               "update on <ns>/<follower>/update (as --ros-updates says), or, from a "
               "follower serving a ROS 2 topic (--ros2-topic), as its own type on "
               "<ns>/<robot>/<topic>; the followers' stats on /diagnostics; a "
               "nav_msgs/msg/Path on <ns>/<follower>/waypoints sets that follower's waypoints, "
               "a std_msgs/msg/Float64 on <ns>/<follower>/weight its weight "
               "(ROS 2 nodes need RMW_IMPLEMENTATION=rmw_zenoh_cpp and this router)")


def add_ros2_arguments(parser: argparse.ArgumentParser, updates: bool = True,
                       what: str = LEADER_HELP) -> None:
    """``--ros2`` (``what`` it does), ``--ros-domain``, ``--ros-namespace`` (and with
    ``updates``, ``--ros-updates`` and ``--ros-max-rate``: how a leader maps its updates,
    how often at most)."""
    parser.add_argument("--ros2", action="store_true", default=None, help=what)
    parser.add_argument("--ros-domain", type=integer(0, MAX_DOMAIN), metavar="D",
                        help="with --ros2: the ROS domain (ROS_DOMAIN_ID; default 0)")
    parser.add_argument("--ros-namespace", metavar="NS",
                        type=ArgType("ros namespace", check_namespace),
                        help="with --ros2: the topics' namespace (default /wiswarm/<swarm>)")
    if not updates:
        return
    parser.add_argument("--ros-updates", metavar="ADAPTER", type=UPDATE_ADAPTER,
                        help="with --ros2: how updates become messages: bytes "
                        "(std_msgs/msg/UInt8MultiArray, the default) or the name of an "
                        "application's adapter (tracking: sensor_msgs/msg/Image and "
                        "geometry_msgs/msg/PoseStamped)")
    parser.add_argument("--ros-max-rate", metavar="HZ", type=positive_float(),
                        help="with --ros2: send each follower's updates at most this often, "
                        "the first delivered once 1/HZ has passed (default: every delivery; "
                        "each costs the leader more than half the CPU of a poll)")


def ros2_options(args: argparse.Namespace) -> Ros2Options | None:
    """The ROS 2 side asked for, or None; a --ros-* flag without --ros2 is an error, and
    --ros2 without the ros2 extra (its message types are loaded when --ros2 is given)."""
    given = [flag for flag in ("ros_domain", "ros_namespace", "ros_updates", "ros_max_rate")
             if getattr(args, flag, None) is not None]
    if not args.ros2:
        if given:
            raise UsageError(f"--{given[0].replace('_', '-')} is for --ros2: add --ros2")
        return None
    require("ros2")
    return Ros2Options(domain=args.ros_domain or 0, namespace=args.ros_namespace,
                       adapter=None if getattr(args, "ros_updates", None) is None
                       else adapter(args.ros_updates),
                       max_rate_hz=getattr(args, "ros_max_rate", None))
