"""Weights from ROS 2 (``wiswarm leader --ros2``): a ``std_msgs/msg/Float64`` on
``<ns>/<member>/weight`` sets that member's application weight, as a put on its weight
key does (``transport.weight_settings``): the weight the application's urgency feeds.

One Zenoh subscriber hears every member's weight topic (``<domain>/<ns>/*/weight/*/*``,
any type), so a member's weight can be set as soon as it is polled, and a topic of no
member is heard and refused. The member is the one polled whose name, made a ROS token
(``graph.ros_token``: ``uav-1`` and ``d1~cam`` are ``uav_1`` and ``d1_cam``), is the
topic's. For ``ros2 topic list`` to show the topic, and ``ros2 topic pub`` to find a
subscriber, each member's has a subscription's liveliness token from the first stats
the bridge gets with it.

What is not a weight (another type, bytes that are no Float64, a number that is not
>= 0, a member not polled, a name two members share) is counted and logged with its key
in the bridge's bad input; the old weight stays.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from typing import Protocol, runtime_checkable

import zenoh

from wiswarm_zenoh.ros2.graph import ros_token, topic_keys
from wiswarm_zenoh.ros2.messages import deserialize, ros_type
from wiswarm_zenoh.ros2.node import Ros2Node
from wiswarm_zenoh.transport import BadInputLog
from wiswarm_zenoh.transport.entities import undeclare

log = logging.getLogger(__name__)

FLOAT64 = "std_msgs/msg/Float64"
LEAF = "weight"
MAX_BYTES = 64  # a Float64's CDR is 12 bytes: anything much longer is not one


@runtime_checkable
class WeightTarget(Protocol):
    """The leader a weight is set on (``LeaderNode``): the members it polls, and
    ``set_weight``, ValueError for a member not polled or a weight not >= 0."""

    @property
    def followers(self) -> list[str]: ...

    def set_weight(self, follower: str, weight: float) -> None: ...


class WeightTopic:
    """The weight topics of ``node``'s namespace ``namespace``, for ``target`` (a leader
    that takes no weights: each sample is refused as bad input), until ``close()``."""

    def __init__(self, session: zenoh.Session, node: Ros2Node, namespace: str,
                 target: object, bad_input: BadInputLog) -> None:
        self._session, self._node, self._namespace = session, node, namespace
        self._target = target if isinstance(target, WeightTarget) else None
        self._bad_input = bad_input
        self._kind = ros_type(FLOAT64)
        self._prefix = topic_keys(node.name.domain, namespace).removesuffix("*/*")
        self._tokens: dict[str, zenoh.LivelinessToken] = {}  # by ROS token of a member
        self._subscriber = session.declare_subscriber(
            topic_keys(node.name.domain, f"{namespace}/*/{LEAF}"), self._on_sample)

    def topic(self, member: str) -> str:
        """``member``'s weight topic."""
        return f"{self._namespace}/{ros_token(member)}/{LEAF}"

    def show(self, members: Iterable[str]) -> None:
        """The members seen (a round of stats): each one's topic in the ROS 2 graph."""
        for member in members:
            token = ros_token(member)
            if token not in self._tokens:
                entity_id = self._node._entity_id()  # one of the node's: rmw_zenoh's graph
                self._tokens[token] = self._session.liveliness().declare_token(
                    self._node.name.endpoint_token(entity_id, "MS", self.topic(member),
                                                   self._kind))

    def _on_sample(self, sample: zenoh.Sample) -> None:  # on Zenoh's thread
        key = str(sample.key_expr)
        try:
            member = self._member(key)
            weight = self._weight(key, sample.payload.to_bytes())
            if self._target is None:
                raise ValueError("this leader takes no weights")
            self._target.set_weight(member, weight)
        except ValueError as exc:
            self._bad_input.report(key, f"weight not set: {exc}")

    def _member(self, key: str) -> str:
        """The member polled whose weight topic ``key`` is on."""
        token = key.removeprefix(self._prefix).split("/", 1)[0]
        members = [] if self._target is None else \
            [m for m in self._target.followers if ros_token(m) == token]
        if len(members) != 1:
            raise ValueError(f"no member polled is {token!r} in ROS 2 names" if not members
                             else f"members {', '.join(members)} are all {token!r} in ROS 2 "
                             "names: set their weights on their weight keys")
        return members[0]

    def _weight(self, key: str, data: bytes) -> float:
        """The Float64 in ``data``, of the key ``key`` (its type's)."""
        if not key.endswith(f"/{self._kind.dds_name}/{self._kind.hash}"):
            raise ValueError(f"a message of another type than {FLOAT64}")
        if len(data) > MAX_BYTES:
            raise ValueError(f"{len(data)} bytes, not a {FLOAT64}")
        return float(deserialize(data, FLOAT64).data)

    def close(self) -> None:
        undeclare(self._subscriber, *self._tokens.values())
