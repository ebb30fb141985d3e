"""A ROS 2 node on an existing Zenoh session, as rmw_zenoh makes one: a liveliness
token for the node and for each publisher and subscription, CDR samples with the
attachment on each topic's data key. Only what the leader needs: publishers that
serialize nothing while no subscriber matches, and subscriptions that count and log
what they cannot take."""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from contextlib import ExitStack
from typing import Any, cast

import zenoh

from wiswarm_zenoh.ros2.graph import GID_BYTES, NodeName, attachment, data_key, topic_keys
from wiswarm_zenoh.ros2.messages import (
    MessageError,
    RosType,
    deserialize,
    ros_type,
    serialize,
)
from wiswarm_zenoh.transport import BadInputLog
from wiswarm_zenoh.transport.entities import undeclare

log = logging.getLogger(__name__)
CDR = zenoh.Encoding("application/cdr")
MAX_MESSAGE_BYTES = 1 << 20  # larger input is refused before it is decoded


class Ros2Publisher:
    """Publishes messages of one type on one topic (from one thread at a time): made
    here and serialized (``publish``), or CDR bytes as they came (``publish_cdr``, of a
    type this process may not even know)."""

    def __init__(self, session: zenoh.Session, node: NodeName, entity_id: int, topic: str,
                 kind: RosType) -> None:
        self.topic, self.type_name = topic, kind.name
        self._gid = os.urandom(GID_BYTES)
        self._sequence = 0
        self._publisher = session.declare_publisher(data_key(node.domain, topic, kind),
                                                    encoding=CDR)
        # Set on Zenoh's thread (a flag); current from the start.
        self.listening = cast(zenoh.MatchingStatus, self._publisher.matching_status).matching
        self._listener = self._publisher.declare_matching_listener(
            zenoh.handlers.Callback(self._on_matching, indirect=False))
        self._token = session.liveliness().declare_token(
            node.endpoint_token(entity_id, "MP", topic, kind))

    def _on_matching(self, status: zenoh.MatchingStatus) -> None:
        self.listening = status.matching

    def publish(self, message: Any) -> None:
        """Serialize and put ``message`` (nothing is done while nobody subscribes)."""
        if self.listening:
            self.publish_cdr(serialize(message, self.type_name), time.time_ns())

    def publish_cdr(self, data: bytes, source_ns: int) -> None:
        """Put ``data``, CDR bytes of this type, stamped ``source_ns`` (the attachment's
        source time, ns since the epoch)."""
        self._sequence += 1
        self._publisher.put(data, attachment=attachment(self._sequence, source_ns, self._gid))

    def close(self) -> None:
        undeclare(self._token, self._listener, self._publisher)


class Ros2Subscription:
    """Hands ``on_message`` each message of ``type_name`` on ``topic`` (Zenoh's thread).

    It listens to every type on the topic: a sample of another type, bytes that are not
    a message of this one, or a message ``on_message`` refuses (raising ValueError) is
    counted and logged in ``bad_input`` with its key, never obeyed."""

    def __init__(self, session: zenoh.Session, node: NodeName, entity_id: int, topic: str,
                 type_name: str, on_message: Callable[[Any], None],
                 bad_input: BadInputLog) -> None:
        self.topic, self.type_name = topic, type_name
        self._key = data_key(node.domain, topic, ros_type(type_name))
        self._on_message = on_message
        self._bad_input = bad_input
        self._subscriber = session.declare_subscriber(topic_keys(node.domain, topic),
                                                      self._on_sample)
        self._token = session.liveliness().declare_token(
            node.endpoint_token(entity_id, "MS", topic, ros_type(type_name)))

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if key != self._key:
            self._bad_input.report(key, f"a message of another type than {self.type_name}")
            return
        payload = sample.payload
        try:
            if len(payload) > MAX_MESSAGE_BYTES:
                raise MessageError(f"{len(payload)} bytes (at most {MAX_MESSAGE_BYTES})")
            self._on_message(deserialize(payload.to_bytes(), self.type_name))
        except ValueError as exc:
            self._bad_input.report(key, str(exc))

    def close(self) -> None:
        undeclare(self._token, self._subscriber)


class Ros2Node:
    """A node ``namespace``/``name`` on ``domain``, until ``close()`` (which undeclares
    its publishers and subscriptions too). What its subscriptions cannot take is counted
    in ``bad_input`` (default: one of this module's logger)."""

    def __init__(self, session: zenoh.Session, name: str, namespace: str, domain: int,
                 bad_input: BadInputLog | None = None) -> None:
        self._session = session
        self.name = NodeName(domain, str(session.info.zid()), 0, namespace, name)
        self.bad_input = BadInputLog(log) if bad_input is None else bad_input
        self._entities = ExitStack()
        self._lock = threading.Lock()
        self._next_id = 1  # rmw_zenoh numbers a context's entities; the node is 0
        token = session.liveliness().declare_token(self.name.token)
        self._entities.callback(undeclare, token)

    def _entity_id(self) -> int:
        with self._lock:
            self._next_id += 1
            return self._next_id - 1

    def publisher(self, topic: str, type_name: str) -> Ros2Publisher:
        """A publisher of ``type_name``, one of the standard messages (the ros2 extra)."""
        return self.publisher_of(topic, ros_type(type_name))

    def publisher_of(self, topic: str, kind: RosType) -> Ros2Publisher:
        """A publisher of ``kind``, any type: its CDR bytes go out as given."""
        publisher = Ros2Publisher(self._session, self.name, self._entity_id(), topic, kind)
        self._entities.callback(publisher.close)
        return publisher

    def subscription(self, topic: str, type_name: str,
                     on_message: Callable[[Any], None]) -> Ros2Subscription:
        subscription = Ros2Subscription(self._session, self.name, self._entity_id(), topic,
                                        type_name, on_message, self.bad_input)
        self._entities.callback(subscription.close)
        return subscription

    def close(self) -> None:
        self._entities.close()
