"""The leader's side of ROS 2-sourced followers: which follower serves which topic of
which type (from their source tokens, see ``topic_source``), and a publisher per
follower that republishes its updates as they came, with that type and hash, CDR bytes
unchanged (the robot's own stamps in them), on ``<ns>/<follower>/<topic without its
leading />``. Never on the source topic's own name: a subscriber there, on the ground,
would make Zenoh route every robot's raw publications over the air."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.core.members import robot_of
from wiswarm_zenoh.ros2.graph import check_topic, ros_token
from wiswarm_zenoh.ros2.messages import RosType
from wiswarm_zenoh.ros2.node import Ros2Node, Ros2Publisher
from wiswarm_zenoh.ros2.topic_source import parse_source_token
from wiswarm_zenoh.transport import BadInputLog, SwarmKeys
from wiswarm_zenoh.transport.discovery import Discovery

log = logging.getLogger(__name__)


class Republisher:
    """Follows the source tokens of ``keys``' swarm (``discovery``: asked again for what
    Zenoh's first answer missed); ``publisher(follower)`` is the publisher of that
    follower's ROS 2 source republished under ``namespace``, or None for a follower that
    serves no ROS 2 topic. ``on_source`` hears of each follower found serving one (the
    leader then awaits its member token)."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys, node: Ros2Node,
                 namespace: str, bad_input: BadInputLog,
                 on_source: Callable[[str], object] = lambda follower: None) -> None:
        self._keys, self._node, self._namespace = keys, node, namespace
        self._bad_input = bad_input
        self._sources: dict[str, tuple[str, RosType]] = {}  # follower: (topic, type)
        self._publishers: dict[tuple[str, str, RosType], Ros2Publisher] = {}
        self._lock = threading.Lock()
        self._on_source = on_source
        self._tokens = Discovery(session, keys.all_sources, self._on_token,
                                 "ROS 2 source token")

    def topic(self, follower: str, source_topic: str) -> str:
        """Where a follower's source topic is republished (a checked ROS name): under its
        robot, so that a robot's streams (``uav1~camera``, ...) keep their own names."""
        return check_topic(f"{self._namespace}/{ros_token(robot_of(follower))}{source_topic}")

    def _on_token(self, key: str, alive: bool) -> None:
        parsed = parse_source_token(self._keys, key)
        if parsed is None:
            self._bad_input.report(key, "not a follower's ROS 2 source token")
            return
        follower, topic, kind = parsed
        with self._lock:
            if alive:
                self._sources[follower] = (topic, kind)
            elif self._sources.get(follower) == (topic, kind):
                del self._sources[follower]
        if alive:
            log.info("follower %s serves ROS 2 topic %s (%s): republished as it came",
                     follower, topic, kind.name)
            self._on_source(follower)

    def publisher(self, follower: str) -> Ros2Publisher | None:
        """The publisher of ``follower``'s source (made on first use, then kept)."""
        with self._lock:
            source = self._sources.get(follower)
            if source is None:
                return None
            found = self._publishers.get((follower, *source))
        if found is None:
            topic, kind = source
            found = self._node.publisher_of(self.topic(follower, topic), kind)
            with self._lock:
                self._publishers[(follower, *source)] = found
        return found

    def close(self) -> None:
        self._tokens.close()
