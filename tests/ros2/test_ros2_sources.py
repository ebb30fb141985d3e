"""A robot's own ROS 2 topic as a follower's source, end to end on real processes: a
publisher in rmw_zenoh's format (CDR from rosbags, its node and publisher tokens) ->
``wiswarm follower --ros2-topic`` -> ``wiswarm leader --ros2`` -> a ROS 2 client nobody
here wrote (zenoh-ros2-sdk), which gets the same type, stamps and bytes on the
republished topic; and the leader's waypoints as a Path on the robot's ROS 2
(``--ros2-waypoints``). Then what goes wrong: a topic never published, a sample too
large, bytes that are not CDR, a sample of another type, a missing attachment."""

from __future__ import annotations

import logging
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import zenoh

from tests.transport.helpers import Recorder, Sessions, eventually, wait_until_known
from wiswarm_zenoh import Follower, FollowerConfig
from wiswarm_zenoh.ros2 import Ros2Options, Ros2TopicSource
from wiswarm_zenoh.ros2.graph import data_key
from wiswarm_zenoh.ros2.messages import header, message_class, ros_type, serialize
from wiswarm_zenoh.ros2.node import Ros2Node
from wiswarm_zenoh.transport import BadInputLog, LeaderNode

ENTRY = ("import sys; from wiswarm_zenoh.cli import main as m, nodes; "
         "sys.exit(m.main(registrars=(nodes.register,)))")
COMPRESSED = "sensor_msgs/msg/CompressedImage"
TOPIC = "/drone1/camera/image_raw/compressed"
DOMAIN = 3
SWARM = "air"
REPUBLISHED = f"/wiswarm/{SWARM}/d1{TOPIC}"
WAYPOINTS = "/drone1/wiswarm/path"
FRAMES = 5  # the client sends back this many of the republished messages
log = logging.getLogger(__name__)


class Camera:
    """A robot's camera node in rmw_zenoh's format, publishing numbered frames at 30 Hz
    from its own thread: frame k's data starts with k, its stamp is when it was made."""

    def __init__(self, session: zenoh.Session, topic: str = TOPIC, size: int = 2000,
                 type_name: str = COMPRESSED) -> None:
        self.node = Ros2Node(session, "camera", "/drone1", DOMAIN, BadInputLog(log))
        self.publisher = self.node.publisher(topic, type_name)
        self.stamps: dict[int, tuple[int, int]] = {}  # frame: (sec, nanosec)
        self._size = size
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def frame(self, k: int) -> Any:
        stamp = header(time.time(), "camera")
        self.stamps[k] = (stamp.stamp.sec, stamp.stamp.nanosec)
        data = k.to_bytes(4, "little") + bytes(i % 251 for i in range(self._size - 4))
        return message_class(COMPRESSED)(header=stamp, format="jpeg",
                                         data=np.frombuffer(data, np.uint8))

    def _run(self) -> None:
        k = 0
        while not self._stop.wait(1 / 30):
            k += 1
            self.publisher.publish_cdr(serialize(self.frame(k), COMPRESSED),
                                       time.time_ns())

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.node.close()


@pytest.fixture
def processes() -> Iterator[list[subprocess.Popen[str]]]:
    started: list[subprocess.Popen[str]] = []
    yield started
    for process in started:
        process.terminate()
    for process in started:
        try:
            process.wait(15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def start(processes: list[subprocess.Popen[str]], port: int, *argv: str) -> None:
    processes.append(subprocess.Popen(
        [sys.executable, "-c", ENTRY, *argv, "-e", f"tcp/127.0.0.1:{port}",
         "--no-multicast-scouting"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True))


def test_a_robots_topic_reaches_ros2_at_the_ground_as_it_was(
        sessions: Sessions, port: int, open_client: Any,
        processes: list[subprocess.Popen[str]]) -> None:
    sessions.router(port)
    camera = Camera(sessions.node(port))
    try:
        start(processes, port, "follower", "--swarm", SWARM, "--id", "d1", "--ros2-topic",
              TOPIC, "--ros-domain", str(DOMAIN), "--ros2-waypoints", WAYPOINTS)
        start(processes, port, "leader", "--swarm", SWARM, "--ros2", "--ros-domain",
              str(DOMAIN))
        client = open_client(port, DOMAIN, [REPUBLISHED, WAYPOINTS],
                             [(REPUBLISHED, COMPRESSED, FRAMES), (WAYPOINTS, "nav_msgs/msg/Path",
                                                                  1)])
        _, topics = client.next("topics")
        assert dict(topics)[REPUBLISHED] == [COMPRESSED]
        assert dict(topics)[WAYPOINTS] == ["nav_msgs/msg/Path"]
        for _ in range(FRAMES):
            _, _, message = client.next("message", REPUBLISHED)
            k = int.from_bytes(bytes(message["data"]["head"][:4]), "little")
            assert message["format"] == "jpeg" and message["data"]["len"] == 2000
            assert message["data"]["head"][4:] == [0, 1, 2, 3]  # the bytes after k, unchanged
            stamp = message["header"]["stamp"]
            assert (stamp["sec"], stamp["nanosec"]) == camera.stamps[k]
            assert message["header"]["frame_id"] == "camera"

        client.publish(f"/wiswarm/{SWARM}/d1/waypoints", "nav_msgs/msg/Path",
                       [(100.0, 1.0, 2.0, 3.0), (101.5, 4.0, 5.0, 6.0)])
        _, _, path = client.next("message", WAYPOINTS)
        assert [(p["header"]["stamp"]["sec"], p["pose"]["position"]["x"],
                 p["pose"]["position"]["z"]) for p in path["poses"]] == [
            (100, 1.0, 3.0), (101, 4.0, 6.0)]
        for process in processes:
            assert process.poll() is None, process.stderr.read() if process.stderr else ""
    finally:
        camera.close()


def republished(session: zenoh.Session, kind: str = COMPRESSED) -> str:
    """The data key the leader republishes d1's source on (``kind`` found on the robot)."""
    return data_key(DOMAIN, REPUBLISHED, ros_type(kind))


def test_what_cannot_be_served_is_counted_never_a_crash(
        sessions: Sessions, port: int, recorder: Recorder,
        caplog: pytest.LogCaptureFixture) -> None:
    """Nothing on the topic yet: one INFO line, and the follower waits. Then a sample too
    large for the follower, a sample of another type and one without an attachment
    (served, stamped at its arrival), and bytes that are not CDR, which the leader
    republishes as they came."""
    caplog.set_level(logging.INFO)
    sessions.router(port)
    robot = sessions.node(port)
    follower = Follower(robot, SWARM, "d1", config=FollowerConfig(max_update_bytes=4096),
                        source=Ros2TopicSource(TOPIC, DOMAIN))
    leader_session = sessions.node(port)
    leader = LeaderNode(leader_session, SWARM, bridge=Ros2Options(domain=DOMAIN),
                        **recorder.callbacks())
    ground = sessions.node(port)
    received: list[bytes] = []
    subscriber = ground.declare_subscriber(republished(ground),
                                           lambda s: received.append(s.payload.to_bytes()))
    # The leader puts nothing while nobody subscribes, and each sample below is sent
    # once: the ground's subscription must have reached it (slow on a busy machine).
    wait_until_known(leader_session, republished(ground))
    try:
        assert any("waiting for the first sample of ROS 2 topic " + TOPIC in r.getMessage()
                   for r in caplog.records)
        camera = Ros2Node(robot, "camera", "/drone1", DOMAIN, BadInputLog(log))
        publisher = camera.publisher(TOPIC, COMPRESSED)
        eventually("the type found from the publisher's token", lambda: any(
            "is a sensor_msgs/msg/CompressedImage" in r.getMessage() for r in caplog.records))
        publisher.publish_cdr(b"\x00\x01" * 4096, time.time_ns())  # too large
        publisher.publish_cdr(b"not CDR at all", time.time_ns())
        eventually("bytes that are not CDR republished as they came",
                   lambda: b"not CDR at all" in received)
        robot.put(data_key(DOMAIN, TOPIC, ros_type("std_msgs/msg/String")), b"x")
        robot.put(data_key(DOMAIN, TOPIC, ros_type(COMPRESSED)), b"no attachment")
        eventually("a sample without an attachment served, stamped at its arrival",
                   lambda: b"no attachment" in received)
        eventually("the wrong type and the missing attachment counted",
                   lambda: follower.bad_input.total() == 2)
        too_large = [r for r in caplog.records if "is not served" in r.getMessage()]
        assert len(too_large) == 1 and "max_update_bytes" in too_large[0].getMessage()
        assert follower.source is not None and follower.source.samples == 2
        camera.close()
    finally:
        subscriber.undeclare()
        leader.close()
        follower.close()


def test_a_topic_of_a_type_this_process_does_not_know_is_republished(
        sessions: Sessions, port: int, recorder: Recorder) -> None:
    """Any message type: the follower and the leader need only its name and hash."""
    sessions.router(port)
    robot = sessions.node(port)
    follower = Follower(robot, SWARM, "d1", source=Ros2TopicSource(TOPIC, DOMAIN))
    leader = LeaderNode(sessions.node(port), SWARM, bridge=Ros2Options(domain=DOMAIN),
                        **recorder.callbacks())
    ground = sessions.node(port)
    custom = "my_robot_msgs::msg::dds_::Telemetry_/RIHS01_" + "ab" * 32
    received: list[tuple[str, bytes]] = []
    subscriber = ground.declare_subscriber(
        f"{DOMAIN}{REPUBLISHED}/*/*",
        lambda s: received.append((str(s.key_expr), s.payload.to_bytes())))
    try:
        eventually("the leader sees d1", lambda: "d1" in recorder.joins)
        key = f"{DOMAIN}{TOPIC}/{custom}"
        stop = threading.Event()

        def publish() -> None:  # until the leader has republished one
            k = 0
            while not stop.wait(0.02):
                k += 1
                robot.put(key, b"telemetry %d" % k,
                          attachment=(1).to_bytes(8, "little") +
                          time.time_ns().to_bytes(8, "little") + bytes([16]) + bytes(16))

        thread = threading.Thread(target=publish, daemon=True)
        thread.start()
        eventually("a message of the unknown type republished", lambda: bool(received))
        stop.set()
        thread.join()
        assert received[0][0] == f"{DOMAIN}{REPUBLISHED}/{custom}"
        assert received[0][1].startswith(b"telemetry ")
    finally:
        subscriber.undeclare()
        leader.close()
        follower.close()
