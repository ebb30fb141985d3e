"""Weights from ROS 2: a ``std_msgs/msg/Float64`` published in rmw_zenoh's format on
``<ns>/<member>/weight`` sets that member's weight at a ``--ros2`` leader; what is not a
weight (another type, bytes that are no Float64, a negative or NaN, a member not polled)
is counted and logged with its key, and the old weight stays."""

from __future__ import annotations

import logging
import math
import time

import pytest
import zenoh

from tests.transport.helpers import Recorder, Sessions, eventually
from wiswarm_zenoh.ros2 import Ros2Bridge, Ros2Options
from wiswarm_zenoh.ros2.graph import ADMIN_SPACE, data_key, mangle
from wiswarm_zenoh.ros2.messages import message_class, ros_type
from wiswarm_zenoh.ros2.node import Ros2Node
from wiswarm_zenoh.transport import BadInputLog, FollowerNode, LeaderNode

SWARM = "weights2"
NS = f"/wiswarm/{SWARM}"
DOMAIN = 5
FLOAT64 = "std_msgs/msg/Float64"
STRING = "std_msgs/msg/String"
log = logging.getLogger(__name__)


def _weight(leader: LeaderNode, follower: str) -> float | None:
    return next((s.weight for s in leader.latest if s.follower == follower), None)


def test_a_float64_on_a_members_weight_topic_sets_its_weight(
        sessions: Sessions, port: int, recorder: Recorder,
        caplog: pytest.LogCaptureFixture) -> None:
    sessions.router(port)
    followers = [FollowerNode(sessions.node(port), SWARM, name) for name in ("uav1", "uav-2")]
    leader = LeaderNode(sessions.node(port), SWARM, bridge=Ros2Options(domain=DOMAIN),
                        every_record=True, **recorder.callbacks())
    tool = sessions.node(port)
    ground = Ros2Node(tool, "ground", "/", DOMAIN, BadInputLog(log))
    try:
        bridge = leader.bridge
        assert isinstance(bridge, Ros2Bridge)
        recorder.wait("both join", lambda r: len(r.joins) == 2)
        # uav-2 as a ROS name is uav_2: its topic shows in the graph once it is polled
        topic = f"{NS}/uav_2/weight"
        _until_listed(tool, topic)
        weight_of, string = ground.publisher(topic, FLOAT64), ground.publisher(topic, STRING)
        ghost = ground.publisher(f"{NS}/uav9/weight", FLOAT64)
        for publisher in (weight_of, string, ghost):
            eventually(f"the leader hears {publisher.topic}", lambda p=publisher: p.listening)
        float64 = message_class(FLOAT64)

        weight_of.publish(float64(data=4.0))
        eventually("uav-2 weighs 4", lambda: _weight(leader, "uav-2") == 4.0)
        assert _weight(leader, "uav1") == 1.0

        caplog.set_level(logging.WARNING)
        for value in (-1.0, math.nan, math.inf):
            weight_of.publish(float64(data=value))
        string.publish(message_class(STRING)(data="4"))
        weight_of.publish_cdr(b"\x00\x01\x00\x00\x00", time.time_ns())  # no Float64
        ghost.publish(float64(data=2.0))
        eventually("six refused", lambda: bridge.bad_input.total() == 6)
        keys = {data_key(DOMAIN, topic, ros_type(kind)) for kind in (FLOAT64, STRING)}
        ghost_key = data_key(DOMAIN, f"{NS}/uav9/weight", ros_type(FLOAT64))
        assert set(bridge.bad_input.counts) == {*keys, ghost_key}
        said = " ".join(r.getMessage() for r in caplog.records)
        assert ghost_key in said and "no member polled is 'uav9'" in said
        assert "another type than std_msgs/msg/Float64" in said
        assert _weight(leader, "uav-2") == 4.0

        weight_of.publish(float64(data=0.5))  # after the bad ones: still heard
        eventually("uav-2 weighs 0.5", lambda: _weight(leader, "uav-2") == 0.5)
    finally:
        ground.close()
        leader.close()
        for follower in followers:
            follower.close()


def _until_listed(session: zenoh.Session, topic: str) -> None:
    """Until the leader's subscription token for ``topic`` is in the ROS 2 graph (what
    ``ros2 topic pub`` waits for)."""
    wanted = f"/MS/%/{mangle(NS)}/wiswarm_leader/{mangle(topic)}/"

    def listed() -> bool:
        return any(wanted in str(reply.ok.key_expr) for reply in session.liveliness().get(
            f"{ADMIN_SPACE}/{DOMAIN}/**", timeout=1.0) if reply.ok is not None)

    eventually(f"{topic} listed", listed)
