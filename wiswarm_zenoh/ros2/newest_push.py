"""Newest-only push of the robot's ROS 2 topic (``wiswarm follower --system push
--newest-only --ros2-topic TOPIC``): the baseline a careful engineer tries first, seen by
a ground subscriber exactly as WiSwarm's deliveries are. The follower takes the topic
where rmw_zenoh publishes it on the robot (``TopicWatch``), keeps only the newest sample
(``NewestPump``) and puts it, CDR bytes and the robot's source time as they came, as a
ROS 2 publisher of the same type on the topic a ``--ros2`` WiSwarm leader republishes
it on, ``<default_namespace(swarm)>/<follower><topic>`` (``republish``). Its puts block
and are reliable (Zenoh's QoS overwrite for that key, ``newest_push_cfg``: the ROS 2
publisher is the usual one), so each sample sent is the newest when the path took the
previous one."""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.baselines.newest import NewestPump
from wiswarm_zenoh.baselines.senders import NEWEST_ZENOH
from wiswarm_zenoh.ros2.bridge import default_namespace
from wiswarm_zenoh.ros2.graph import check_topic, ros_token, topic_keys
from wiswarm_zenoh.ros2.messages import NS_PER_S, RosType
from wiswarm_zenoh.ros2.node import Ros2Node, Ros2Publisher
from wiswarm_zenoh.ros2.topic_source import Ros2TopicSource, TopicWatch
from wiswarm_zenoh.transport import BadInputLog

log = logging.getLogger(__name__)

NODE_NAME = "wiswarm_newest_push"
Sample = tuple[bytes, int, RosType]  # CDR bytes, source time (ns), type


def republished_topic(swarm: str, follower: str, topic: str) -> str:
    """Where a WiSwarm ``--ros2`` leader republishes ``follower``'s ``topic`` (default
    namespace), and so where newest-only push publishes it."""
    return check_topic(f"{default_namespace(swarm)}/{ros_token(follower)}{topic}")


def newest_push_cfg(swarm: str, follower: str, source: Ros2TopicSource) -> tuple[str, ...]:
    """The follower's session ``--cfg`` entries: ``NEWEST_ZENOH``, and the puts on the
    republished topic block and are reliable."""
    key = topic_keys(source.domain, republished_topic(swarm, follower, source.topic))
    qos = [{"key_exprs": [key],
            "config": {"congestion_control": "block", "reliability": "reliable"}}]
    return (*NEWEST_ZENOH, f"qos/publication:{json.dumps(qos)}")


class Ros2NewestPush:
    """Pushes the newest sample of ``source`` as ``follower`` of ``swarm`` on ``topic``
    until ``close()``; ``queue`` counts the samples. The publisher is made, used and
    undeclared on the pump's thread alone (``fifo.FramePump`` says why)."""

    def __init__(self, session: zenoh.Session, swarm: str, follower: str,
                 source: Ros2TopicSource, clock: Callable[[], float] = time.time) -> None:
        self.topic = republished_topic(swarm, follower, source.topic)
        self._clock = clock
        bad_input = BadInputLog(log)
        self._node = Ros2Node(session, NODE_NAME, f"{default_namespace(swarm)}/"
                              f"{ros_token(follower)}", source.domain, bad_input)
        self._publisher: Ros2Publisher | None = None
        self.queue: NewestPump[Sample] = NewestPump(follower, self._send, clock,
                                                    self._node.close)
        self._watch = TopicWatch(session, source, f"follower {follower}", bad_input,
                                 self._on_sample)
        log.info("follower %s: the newest sample of %s goes to %s", follower, source.topic,
                 self.topic)

    def _on_sample(self, cdr: bytes, source_ns: int | None, kind: RosType) -> None:
        stamp = round(self._clock() * NS_PER_S) if source_ns is None else source_ns
        self.queue.offer((cdr, stamp, kind), stamp / NS_PER_S, stamp)

    def _send(self, sample: Sample, generated_at: float, seq: int) -> None:
        cdr, source_ns, kind = sample
        if self._publisher is None:  # one type: the topic's, found before its first sample
            self._publisher = self._node.publisher_of(self.topic, kind)
        self._publisher.publish_cdr(cdr, source_ns)

    def close(self) -> None:
        self._watch.close()
        self.queue.close()
