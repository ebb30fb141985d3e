"""The leader as a ROS 2 participant (``wiswarm leader --ros2``): each delivered update
as the application's messages on ``<ns>/<follower>/<leaf>`` (a follower serving a ROS 2
topic: as the message it is, on ``<ns>/<follower>/<topic>``, see ``republish``), the
followers' stats on ``/diagnostics``, and a ``nav_msgs/msg/Path`` on
``<ns>/<follower>/waypoints`` as that follower's control, checked as ``set_control``
checks any caller's, and a ``std_msgs/msg/Float64`` on ``<ns>/<follower>/weight`` as its
weight (``weight_topic``).

The poll thread only leaves each delivery in its follower's slot (``Freshest``); a
thread of the bridge's own maps, serializes and puts it. A delivery that finds an older
one of its follower still unsent replaces it (``superseded``): ROS 2 gets the freshest
update of each follower, never a queue of stale ones, and polling never waits for it.
With ``max_rate_hz``, a follower's deliveries sooner than its period after the last one
left are not left at all (``throttled``): each update sent costs the leader's process
more than half the CPU a poll costs it, which a busy machine takes from polling."""

from __future__ import annotations

import logging
import math
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
from wiswarm_zenoh.ros2.messages import DIAGNOSTIC_ARRAY, NS_PER_S, PATH
from wiswarm_zenoh.ros2.node import Ros2Node, Ros2Publisher
from wiswarm_zenoh.ros2.republish import Republisher
from wiswarm_zenoh.ros2.waypoints import path_waypoints
from wiswarm_zenoh.ros2.weight_topic import WeightTopic
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
    ``/wiswarm/<swarm>``), the application's ``adapter`` (default: bytes), and
    ``max_rate_hz``: each follower's updates go out at most this often, the first
    delivered once the period has passed (default: every delivery). Give it to
    ``LeaderNode(bridge=...)``."""

    domain: int = 0
    namespace: str | None = None
    adapter: UpdateAdapter | None = None
    max_rate_hz: float | None = None

    def __post_init__(self) -> None:
        check_domain(self.domain)
        if self.namespace is not None:
            check_namespace(self.namespace)
        rate = self.max_rate_hz
        if rate is not None and (isinstance(rate, bool) or not isinstance(rate, int | float)
                                 or not (math.isfinite(rate) and rate > 0)):
            raise ValueError(f"max_rate_hz must be a positive number of Hz, got {rate!r}")

    def open(self, session: zenoh.Session, swarm: str, control: ControlTarget) -> Ros2Bridge:
        return Ros2Bridge(session, swarm, self, control)


class Ros2Bridge:
    """One ROS 2 node, ``<namespace>/wiswarm_leader``, for the leader of ``swarm``, and
    the thread that publishes its deliveries, until ``close()``. ``published`` counts the
    deliveries sent, ``superseded`` those replaced unsent by a newer one, ``throttled``
    those over ``max_rate_hz``."""

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
        self._republisher = Republisher(session, self._keys, self._node, self.namespace,
                                        self.bad_input, control.expect)
        self._weights = WeightTopic(session, self._node, self.namespace, control,
                                    self.bad_input)
        self._followers: dict[str, list[Ros2Publisher]] = {}
        self._waypoint_topics: set[str] = set()  # followers whose Path is listened to
        # Per follower, the freshest delivery unsent and its publishers (None: its source's
        # own message, republished as it came).
        self._unsent: Freshest[str, tuple[list[Ros2Publisher] | None, Delivered]] = \
            Freshest()
        self._period = 0.0 if options.max_rate_hz is None else 1.0 / options.max_rate_hz
        self._next_at: dict[str, float] = {}  # per follower: the earliest delivery to send
        self.published = self.superseded = self.throttled = 0
        self._thread = threading.Thread(target=self._publish_deliveries,
                                        name=f"ros2-{swarm}", daemon=True)
        self._thread.start()
        log.info("ROS 2 node %s/%s on domain %d", self.namespace, NODE_NAME, options.domain)

    def topic(self, follower: str, leaf: str) -> str:
        """``<namespace>/<follower>/<leaf>``, the follower's name made a ROS token."""
        return f"{self.namespace}/{ros_token(follower)}/{leaf}"

    def publisher(self, topic: str, type_name: str) -> Ros2Publisher:
        """A publisher of the application's own on this node (e.g. of what it makes of
        the updates), undeclared with it; publish from one thread."""
        return self._node.publisher(topic, type_name)

    def deliver(self, event: Delivered) -> None:
        """Leave ``event`` for the publishing thread (on the poll thread: no more)."""
        source = self._source(event.follower)
        publishers = self._publishers(event.follower) if source is None else [source]
        if not any(publisher.listening for publisher in publishers):
            return
        if event.delivered_at < self._next_at.get(event.follower, -math.inf):
            self.throttled += 1
            return
        self._next_at[event.follower] = event.delivered_at + self._period
        self.superseded += self._unsent.put(
            event.follower, (None if source is not None else publishers, event)) is not None

    def _publish_deliveries(self) -> None:
        while (item := self._unsent.take()) is not None:
            follower, (publishers, event) = item
            try:
                self._publish(publishers, event)
            except Exception:  # logged, as a failed callback of the leader's: go on
                log.exception("ROS 2: %s's update at %.6f not published", follower,
                              event.generated_at)

    def _publish(self, publishers: list[Ros2Publisher] | None, event: Delivered) -> None:
        if publishers is None:  # a ROS 2 source's message: as it came, whatever it holds
            source = self._source(event.follower)
            if source is not None:
                source.publish_cdr(event.payload, round(event.generated_at * NS_PER_S))
                self.published += 1
            return
        try:
            messages = self._adapter.messages(event.follower, event.payload, event.generated_at)
        except (ValueError, WireError) as exc:
            self.bad_input.report(self._keys.update(event.follower), f"not mapped: {exc}")
            return
        for publisher, message in zip(publishers, messages, strict=True):
            publisher.publish(message)
        self.published += 1

    def stats(self, records: Sequence[FollowerStats], now: float) -> None:
        self._weights.show(record.follower for record in records)
        for record in records:
            if record.present and self._source(record.follower) is None:
                self._publishers(record.follower)
        if self._diagnostics.listening:
            self._diagnostics.publish(diagnostic_array(self._keys.swarm, records, now))

    def _source(self, follower: str) -> Ros2Publisher | None:
        """The publisher of a follower's ROS 2 source republished (and its waypoint
        subscription), or None if it serves none."""
        source = self._republisher.publisher(follower)
        if source is not None:
            self._waypoints_in(follower)
        return source

    def _publishers(self, follower: str) -> list[Ros2Publisher]:
        """A follower's publishers, made when it is first seen (and kept: a follower may
        come back)."""
        publishers = self._followers.get(follower)
        if publishers is None:
            self._waypoints_in(follower)
            publishers = [self._node.publisher(self.topic(follower, out.leaf), out.type_name)
                          for out in self._adapter.outputs]
            self._followers[follower] = publishers
        return publishers

    def _waypoints_in(self, follower: str) -> None:
        """The follower's waypoint subscription, once."""
        if follower not in self._waypoint_topics:
            self._waypoint_topics.add(follower)
            self._node.subscription(self.topic(follower, "waypoints"), PATH,
                                    partial(self._waypoints, follower))

    def _waypoints(self, follower: str, path: Any) -> None:
        waypoints = path_waypoints(path)
        self._control.set_control(follower, waypoints)  # ValueError: counted by the node
        log.debug("%d waypoints for %s from ROS 2", len(waypoints), follower)

    def close(self) -> None:
        """Stop publishing (what is unsent is dropped) and undeclare the node."""
        self._unsent.close()
        self._thread.join()
        self._republisher.close()
        self._weights.close()
        self._node.close()
        log.info("ROS 2: %d deliveries published, %d superseded unsent by a newer one, "
                 "%d over the rate limit", self.published, self.superseded, self.throttled)
