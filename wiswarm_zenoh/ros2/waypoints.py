"""Waypoints and ROS 2's ``nav_msgs/msg/Path``, both ways: a Path in from a ROS 2 node
sets a follower's waypoints at the leader (``path_waypoints``); on the robot, a
follower's waypoints go out as a Path for its navigation stack or offboard node
(``WaypointsPublisher``, ``wiswarm follower --ros2-waypoints``). Each pose's position is
a waypoint's place and its stamp the waypoint's time."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from typing import Any

import zenoh

from wiswarm_zenoh.core import Waypoint
from wiswarm_zenoh.ros2.graph import check_domain, check_topic, ros_token
from wiswarm_zenoh.ros2.messages import PATH, header, message_class, seconds
from wiswarm_zenoh.ros2.node import Ros2Node
from wiswarm_zenoh.transport import BadInputLog

log = logging.getLogger(__name__)

FRAME_ID = "map"  # the waypoints' frame: the leader's world coordinates


def path_waypoints(path: Any) -> list[Waypoint]:
    """``(t, x, y, z)`` of each pose of ``path``, as the leader's ``set_control`` takes
    them (which checks them: finite, at most the wire's number)."""
    return [(seconds(pose.header.stamp), float(pose.pose.position.x),
             float(pose.pose.position.y), float(pose.pose.position.z))
            for pose in path.poses]


def waypoints_path(waypoints: Sequence[Waypoint], at: float, frame_id: str = FRAME_ID) -> Any:
    """A Path stamped ``at`` whose poses are ``waypoints`` (no turn: identity
    orientation), in ``frame_id``."""
    pose_stamped, pose, point, quaternion = (message_class(f"geometry_msgs/msg/{name}") for name
                                             in ("PoseStamped", "Pose", "Point", "Quaternion"))
    return message_class(PATH)(header=header(at, frame_id), poses=[
        pose_stamped(header=header(t, frame_id), pose=pose(
            position=point(x=float(x), y=float(y), z=float(z)),
            orientation=quaternion(x=0.0, y=0.0, z=0.0, w=1.0)))
        for t, x, y, z in waypoints])


class WaypointsPublisher:
    """A follower's waypoints as ``nav_msgs/msg/Path`` on ``topic`` of the robot's ROS 2
    (domain ``domain``), from the ROS node ``/wiswarm_follower_<follower>``: give it to
    the follower as ``on_control``; ``close()`` undeclares it. Needs the ros2 extra."""

    def __init__(self, session: zenoh.Session, follower: str, topic: str, domain: int = 0,
                 clock: Callable[[], float] = time.time) -> None:
        check_topic(topic)
        check_domain(domain)
        self._node = Ros2Node(session, f"wiswarm_follower_{ros_token(follower)}",
                              "", domain, BadInputLog(log))
        self._publisher = self._node.publisher(topic, PATH)
        self._clock = clock
        self.published = 0  # Paths put (none while no ROS 2 node subscribes)
        log.info("follower %s: waypoints go out as %s on %s (domain %d)", follower, PATH,
                 topic, domain)

    def __call__(self, waypoints: list[Waypoint]) -> None:
        if self._publisher.listening:
            self._publisher.publish(waypoints_path(waypoints, self._clock()))
            self.published += 1

    def close(self) -> None:
        self._node.close()
