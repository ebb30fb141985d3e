"""A ROS 2 topic as a follower's source (``wiswarm follower --ros2-topic``), taken from
rmw_zenoh where the robot already publishes it: nothing is decoded on the robot, so any
message type works and the ros2 extra is not needed.

The topic's type and RIHS01 hash are found from the first publisher's liveliness token
(``@ros2_lv/<D>/.../MP/.../<topic>/<type>/<hash>/...``) or the first data key seen
(``<D>/<topic>/<type>/<hash>``); samples of any other type on the topic are counted as
bad input, never served. Each sample's CDR bytes are offered as they came, generated at
the source time of its attachment put on the follower's clock (``SourceTimes``: used as
it is where the publisher keeps this host's clock, as rmw_zenoh does; mapped where it
keeps one of its own, as PX4 does with microseconds since its boot), else at its
arrival. Once the type is known the follower holds the token
``wiswarm/<swarm>/<follower>/source/ros2/<topic>/<type>/<hash>``, by which a ``--ros2``
leader republishes the updates with that type (``republish``)."""

from __future__ import annotations

import logging
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass

import zenoh

from wiswarm_zenoh.ros2.graph import (
    ADMIN_SPACE,
    check_domain,
    check_topic,
    mangle,
    source_time_ns,
    topic_keys,
    type_name_of,
    unmangle,
)
from wiswarm_zenoh.ros2.messages import NS_PER_S, RosType
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.discovery import Discovery
from wiswarm_zenoh.transport.entities import Declared, undeclare
from wiswarm_zenoh.transport.follower_node import FollowerNode
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.source_feed import Feed, SourceTimes

log = logging.getLogger(__name__)

_HASH = re.compile(r"RIHS01_[0-9a-f]{64}")
SOURCE_KIND = "ros2"


def found_type(dds_name: str, type_hash: str) -> RosType | None:
    """The type named in a key (DDS name and RIHS01 hash), or None if they are not."""
    name = type_name_of(dds_name)
    return None if name is None or not _HASH.fullmatch(type_hash) else \
        RosType(name, dds_name, type_hash)


def source_token(keys: SwarmKeys, follower: str, topic: str, kind: RosType) -> str:
    return f"{keys.source(follower)}/{SOURCE_KIND}/{mangle(topic)}/{kind.dds_name}/{kind.hash}"


def parse_source_token(keys: SwarmKeys, key: str) -> tuple[str, str, RosType] | None:
    """``(follower, topic, type)`` of a follower's ROS 2 source token; None otherwise."""
    parts = key.split("/")
    if len(parts) != 8 or parts[:2] != keys.prefix.split("/") or \
            parts[3:5] != ["source", SOURCE_KIND]:
        return None
    kind = found_type(parts[6], parts[7])
    try:
        follower, topic = keys.follower_of(keys.update(parts[2]), "update"), \
            check_topic(unmangle(parts[5]))
    except ValueError:
        return None
    return None if follower is None or kind is None else (follower, topic, kind)


def described(source: Ros2TopicSource) -> str:
    """How the log names ``source``."""
    return f"ROS 2 topic {source.topic} (domain {source.domain})"


@dataclass(frozen=True)
class Ros2TopicSource:
    """The ROS 2 topic ``topic`` (a full name, ``/drone1/camera/image_raw/compressed``)
    on ROS domain ``domain``, as rmw_zenoh publishes it."""

    topic: str
    domain: int = 0

    def __post_init__(self) -> None:
        check_topic(self.topic)
        check_domain(self.domain)

    def open(self, session: zenoh.Session, node: FollowerNode) -> TopicFeed:
        """Look for the topic on ``session`` and feed ``node`` (the follower does this)."""
        return TopicFeed(session, self, node)


class TopicWatch:
    """The samples of ``source``'s topic, of its type only (found as the module says):
    ``on_sample(cdr, source_ns, type)`` for each (on Zenoh's thread; ``source_ns`` the
    attachment's source time on this host's clock, ``times``, or None where the
    attachment gives none, reported in ``bad_input``) and, once, ``on_type(type)`` when
    the type is found, under a lock that ``close`` takes too. ``who`` names the follower
    in the log."""

    def __init__(self, session: zenoh.Session, source: Ros2TopicSource, who: str,
                 bad_input: BadInputLog, on_sample: Callable[[bytes, int | None, RosType], object],
                 on_type: Callable[[RosType], object] = lambda kind: None,
                 times: SourceTimes | None = None) -> None:
        self._source, self._who, self._bad_input = source, who, bad_input
        self._times = SourceTimes(who, described(source)) if times is None else times
        self._on_sample_of, self._on_type = on_sample, on_type
        self.type: RosType | None = None
        self._found = threading.Lock()
        self._closed = False
        self._data = session.declare_subscriber(
            topic_keys(source.domain, source.topic),
            zenoh.handlers.Callback(self._on_sample, indirect=False))
        # Asked again faster until the type is known (``discovery``).
        self._publishers = Discovery(
            session, f"{ADMIN_SPACE}/{source.domain}/*/*/*/MP/*/*/*/{mangle(source.topic)}/*/*/*",
            self._on_publisher, "ROS 2 publisher token", expecting=lambda: self.type is None)

    def _on_publisher(self, key: str, alive: bool) -> None:
        if alive:
            parts = key.split("/")
            self._found_on(parts[-3], parts[-2], "a publisher's liveliness token")

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        _, dds_name, type_hash = key.rsplit("/", 2)
        kind = self._found_on(dds_name, type_hash, "its first data key")
        if kind is None:
            known = self.type
            self._bad_input.report(key, "a data key that names no message type"
                                   if known is None else
                                   f"another type than the topic's {known.name}")
            return
        source_ns: int | None = None
        attached = sample.attachment
        try:
            if attached is None:
                raise ValueError("no attachment")
            source_ns = self._times.at(source_time_ns(attached.to_bytes()))
        except ValueError as exc:  # served, stamped at its arrival
            self._bad_input.report(key, f"{exc}: stamped at its arrival")
        self._on_sample_of(sample.payload.to_bytes(), source_ns, kind)

    def _found_on(self, dds_name: str, type_hash: str, how: str) -> RosType | None:
        """The topic's type if it is the one named (the first one named becomes it)."""
        with self._found:
            if self.type is not None:
                same = (dds_name, type_hash) == (self.type.dds_name, self.type.hash)
                return self.type if same else None
            kind = found_type(dds_name, type_hash)
            if kind is None or self._closed:
                return None
            self.type = kind
            self._on_type(kind)
        log.info("%s: ROS 2 topic %s is a %s (%s), found by %s", self._who,
                 self._source.topic, kind.name, kind.hash, how)
        return kind

    def close(self) -> None:
        """No ``on_sample`` starts, nor ``on_type``, once this returns."""
        self._publishers.close()
        undeclare(self._data)
        with self._found:
            self._closed = True


class TopicFeed(Feed):
    """Feeds ``node`` with ``source``'s samples until ``close()``; ``type`` is the
    topic's type once found."""

    def __init__(self, session: zenoh.Session, source: Ros2TopicSource,
                 node: FollowerNode) -> None:
        super().__init__(node, described(source),
                         "`ros2 topic list` on the robot lists its topics")
        self._session, self._source, self._node = session, source, node
        self._token: Declared | None = None
        who = f"follower {node.follower_id}"
        self._watch = TopicWatch(session, source, who, node.bad_input, self._on_sample,
                                 self._on_type, SourceTimes(who, self.what, self.now))

    @property
    def type(self) -> RosType | None:
        return self._watch.type

    def _on_type(self, kind: RosType) -> None:
        self._token = self._session.liveliness().declare_token(source_token(
            self._node.keys, self._node.follower_id, self._source.topic, kind))

    def _on_sample(self, payload: bytes, source_ns: int | None, kind: RosType) -> None:
        arrived_at = self.now()
        self.offer(payload, arrived_at if source_ns is None else source_ns / NS_PER_S,
                   arrived_at)

    def close(self) -> None:
        self._watch.close()
        if self._token is not None:
            undeclare(self._token)
        self.closed()
