"""Waypoints in from ROS 2: a ``nav_msgs/msg/Path`` whose poses are a follower's
waypoints, each pose's position the place and its stamp the time."""

from __future__ import annotations

from typing import Any

from wiswarm_zenoh.core import Waypoint
from wiswarm_zenoh.ros2.messages import seconds


def path_waypoints(path: Any) -> list[Waypoint]:
    """``(t, x, y, z)`` of each pose of ``path``, as the leader's ``set_control`` takes
    them (which checks them: finite, at most the wire's number)."""
    return [(seconds(pose.header.stamp), float(pose.pose.position.x),
             float(pose.pose.position.y), float(pose.pose.position.z))
            for pose in path.poses]
