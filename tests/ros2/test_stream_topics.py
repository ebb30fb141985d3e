"""A robot's several ROS 2 topics served by one follower process, each a stream member
(``d1~cam``, ``d1~odom``): a ``--ros2`` leader republishes each under the robot,
``NS/d1/<topic>``, as it does a robot's single topic, so that a ground subscriber's
names do not depend on how many topics the robot serves."""

from __future__ import annotations

import logging
import threading
import time

import zenoh

from tests.transport.helpers import Recorder, Sessions, eventually
from wiswarm_zenoh import Follower
from wiswarm_zenoh.ros2 import Ros2Options, Ros2TopicSource
from wiswarm_zenoh.ros2.graph import data_key
from wiswarm_zenoh.ros2.messages import ros_type
from wiswarm_zenoh.ros2.node import Ros2Node
from wiswarm_zenoh.transport import BadInputLog, LeaderNode
from wiswarm_zenoh.transport.keys import stream_member

SWARM = "streams2"
DOMAIN = 4
STRING = "std_msgs/msg/String"
TOPICS = {"cam": "/drone1/camera", "odom": "/drone1/odometry"}
log = logging.getLogger(__name__)


def test_each_stream_is_republished_under_its_robot(
        sessions: Sessions, port: int, recorder: Recorder) -> None:
    sessions.router(port)
    robot = sessions.node(port)
    followers = [Follower(robot, SWARM, stream_member("d1", name),
                          source=Ros2TopicSource(topic, DOMAIN))
                 for name, topic in TOPICS.items()]
    leader = LeaderNode(sessions.node(port), SWARM, bridge=Ros2Options(domain=DOMAIN),
                        **recorder.callbacks())
    ground = sessions.node(port)
    received: dict[str, list[bytes]] = {topic: [] for topic in TOPICS.values()}
    subscribers = [ground.declare_subscriber(
        data_key(DOMAIN, f"/wiswarm/{SWARM}/d1{topic}", ros_type(STRING)),
        lambda s, topic=topic: received[topic].append(s.payload.to_bytes()))
        for topic in TOPICS.values()]
    node = Ros2Node(robot, "robot", "/drone1", DOMAIN, BadInputLog(log))
    publishers = {topic: node.publisher(topic, STRING) for topic in TOPICS.values()}
    stop = threading.Event()

    def publish() -> None:  # until both are republished
        k = 0
        while not stop.wait(0.02):
            k += 1
            for topic, publisher in publishers.items():
                publisher.publish_cdr(b"%s %d" % (topic.encode(), k), time.time_ns())

    thread = threading.Thread(target=publish, daemon=True)
    try:
        eventually("both streams joined", lambda: len(set(recorder.joins)) == 2)
        thread.start()
        eventually("both republished under d1", lambda: all(received.values()))
        for topic, payloads in received.items():
            assert all(p.startswith(topic.encode()) for p in payloads)
    finally:
        stop.set()
        if thread.is_alive():
            thread.join()
        for subscriber in subscribers:
            subscriber.undeclare()
        node.close()
        leader.close()
        for follower in followers:
            follower.close()


def test_a_stream_member_is_one_key_chunk_zenoh_takes() -> None:
    member = stream_member("d1", "cam")
    assert member == "d1~cam"
    key = zenoh.KeyExpr(f"wiswarm/{SWARM}/{member}/update")
    assert key.intersects(zenoh.KeyExpr(f"wiswarm/{SWARM}/*/update"))
    assert not key.intersects(zenoh.KeyExpr(f"wiswarm/{SWARM}/d1/update"))
