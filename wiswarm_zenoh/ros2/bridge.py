"""The leader as a ROS 2 participant (``wiswarm leader --ros2``): each delivered update
as the application's messages on ``<ns>/<follower>/<leaf>``, the followers' stats on
``/diagnostics``, and a ``nav_msgs/msg/Path`` on ``<ns>/<follower>/waypoints`` as that
follower's control, checked as ``set_control`` checks any caller's.

The poll thread only leaves each delivery in its follower's slot (``Freshest``); a
thread of the bridge's own maps, serializes and puts it. A delivery that finds an older
one of its follower still unsent replaces it (``superseded``): ROS 2 gets the freshest
update of each follower, never a queue of stale ones, and polling never waits for it."""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import zenoh

from wiswarm_zenoh.core import Delivered, FollowerStats, WireError
from wiswarm_zenoh.ros2.adapters import BytesAdapter, UpdateAdapter
from wiswarm_zenoh.ros2.diagnostics import diagnostic_array
from wiswarm_zenoh.ros2.graph import check_domain, check_namespace, ros_token
from wiswarm_zenoh.ros2.messages import DIAGNOSTIC_ARRAY, PATH
from wiswarm_zenoh.ros2.node import Ros2Node, Ros2Publisher
from wiswarm_zenoh.ros2.waypoints import path_waypoints
from wiswarm_zenoh.transport import BadInputLog, Freshest, SwarmKeys
from wiswarm_zenoh.transport.bridge import ControlTarget

log = logging.getLogger(__name__)

NODE_NAME = "wiswarm_leader"
DIAGNOSTICS = "/diagnostics"


def default_namespace(swarm: str) -> str:
    return f"/wiswarm/{ros_token(swarm)}"


@dataclass(frozen=True)
class Ros2Options:
    """The leader's ROS 2 side: ``domain`` (``ROS_DOMAIN_ID``), ``namespace`` (default
    ``/wiswarm/<swarm>``) and the application's ``adapter`` (default: bytes). Give it to
    ``LeaderNode(bridge=...)``."""

    domain: int = 0
    namespace: str | None = None
    adapter: UpdateAdapter | None = None

    def __post_init__(self) -> None:
        check_domain(self.domain)
        if self.namespace is not None:
            check_namespace(self.namespace)

    def open(self, session: zenoh.Session, swarm: str, control: ControlTarget) -> Ros2Bridge:
        return Ros2Bridge(session, swarm, self, control)


class Ros2Bridge:
    """One ROS 2 node, ``<namespace>/wiswarm_leader``, for the leader of ``swarm``, and
    the thread that publishes its deliveries, until ``close()``. ``published`` counts the
    deliveries sent, ``superseded`` those replaced unsent by a newer one."""

    def __init__(self, session: zenoh.Session, swarm: str, options: Ros2Options,
                 control: ControlTarget) -> None:
        self._keys = SwarmKeys(swarm)
        self.namespace = options.namespace or default_namespace(swarm)
        self.bad_input = BadInputLog(log)
        self._node = Ros2Node(session, NODE_NAME, self.namespace, options.domain,
                              self.bad_input)
        self._adapter = options.adapter if options.adapter is not None else BytesAdapter()
        self._control = control
        self._diagnostics = self._node.publisher(DIAGNOSTICS, DIAGNOSTIC_ARRAY)
        self._followers: dict[str, list[Ros2Publisher]] = {}
        self._unsent: Freshest[str, tuple[list[Ros2Publisher], Delivered]] = Freshest()
        self.published = self.superseded = 0
        self._thread = threading.Thread(target=self._publish_deliveries,
                                        name=f"ros2-{swarm}", daemon=True)
        self._thread.start()
        log.info("ROS 2 node %s/%s on domain %d", self.namespace, NODE_NAME, options.domain)

    def topic(self, follower: str, leaf: str) -> str:
        """``<namespace>/<follower>/<leaf>``, the follower's name made a ROS token."""
        return f"{self.namespace}/{ros_token(follower)}/{leaf}"

    def deliver(self, event: Delivered) -> None:
        """Leave ``event`` for the publishing thread (on the poll thread: no more)."""
        publishers = self._publishers(event.follower)
        if any(publisher.listening for publisher in publishers):
            self.superseded += self._unsent.put(event.follower, (publishers, event)) is not None

    def _publish_deliveries(self) -> None:
        while (item := self._unsent.take()) is not None:
            follower, (publishers, event) = item
            try:
                self._publish(publishers, event)
            except Exception:  # logged, as a failed callback of the leader's: go on
                log.exception("ROS 2: %s's update at %.6f not published", follower,
                              event.generated_at)

    def _publish(self, publishers: list[Ros2Publisher], event: Delivered) -> None:
        try:
            messages = self._adapter.messages(event.follower, event.payload, event.generated_at)
        except (ValueError, WireError) as exc:
            self.bad_input.report(self._keys.update(event.follower), f"not mapped: {exc}")
            return
        for publisher, message in zip(publishers, messages, strict=True):
            publisher.publish(message)
        self.published += 1

    def stats(self, records: Sequence[FollowerStats], now: float) -> None:
        for record in records:
            if record.present:
                self._publishers(record.follower)
        if self._diagnostics.listening:
            self._diagnostics.publish(diagnostic_array(self._keys.swarm, records, now))

    def _publishers(self, follower: str) -> list[Ros2Publisher]:
        """A follower's publishers, and its waypoint subscription, made when it is first
        seen (and kept: a follower may come back)."""
        publishers = self._followers.get(follower)
        if publishers is None:
            publishers = [self._node.publisher(self.topic(follower, out.leaf), out.type_name)
                          for out in self._adapter.outputs]
            self._node.subscription(self.topic(follower, "waypoints"), PATH,
                                    partial(self._waypoints, follower))
            self._followers[follower] = publishers
        return publishers

    def _waypoints(self, follower: str, path: Any) -> None:
        waypoints = path_waypoints(path)
        self._control.set_control(follower, waypoints)  # ValueError: counted by the node
        log.debug("%d waypoints for %s from ROS 2", len(waypoints), follower)

    def close(self) -> None:
        """Stop publishing (what is unsent is dropped) and undeclare the node."""
        self._unsent.close()
        self._thread.join()
        self._node.close()
        log.info("ROS 2: %d deliveries published, %d superseded unsent by a newer one",
                 self.published, self.superseded)
