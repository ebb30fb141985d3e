"""One follower process, several streams (``wiswarm follower --source`` given more than
once): each stream is a member of its own, named as the docs say, polled and aged on
its own; the leader knows them as one robot; a robot that dies takes them all."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator

import pytest
import zenoh

from tests.transport.helpers import Recorder, Sessions, eventually
from wiswarm_zenoh.transport import LeaderNode
from wiswarm_zenoh.transport.source_feed import ZenohSource
from wiswarm_zenoh.transport.streams import robot_streams, stream_name

ENTRY = ("import sys; from wiswarm_zenoh.cli import main as m, nodes; "
         "sys.exit(m.main(registrars=(nodes.register,)))")
SWARM = "streams"


def test_a_lone_unnamed_stream_is_the_robot_and_others_are_robot_tilde_name() -> None:
    camera, odometry = ZenohSource("uav1/camera"), ZenohSource("uav1/odom/**")
    assert [s.member for s in robot_streams("uav1", [(None, camera, "uav1/camera")])] == \
        ["uav1"]
    assert [s.member for s in robot_streams("uav1", [("cam", camera, "uav1/camera")])] == \
        ["uav1~cam"]
    assert [s.member for s in robot_streams("uav1", [
        (None, camera, "uav1/camera"), (None, odometry, "uav1/odom/**")])] == \
        ["uav1~uav1_camera", "uav1~uav1_odom"]
    assert stream_name("/drone1/camera/image_raw/compressed") == \
        "drone1_camera_image_raw_compressed"


@pytest.mark.parametrize("given,why", [
    ([(None, "a/b"), (None, "a/b")], "a/b given twice"),
    ([(None, "a/b"), (None, "a/b/**")], "are both member 'uav1~a_b': name one"),
    ([("x", "a/b"), ("x", "c")], "are both member 'uav1~x'"),
    ([(None, "a/" + "b" * 130), (None, "c")], "bytes long (at most 128): name it"),
    ([(None, "**"), (None, "c")], "has no letter or digit to name its stream"),
])
def test_streams_that_cannot_be_told_apart_say_why(
        given: list[tuple[str | None, str]], why: str) -> None:
    with pytest.raises(ValueError, match=why.replace("(", r"\(").replace(")", r"\)")):
        robot_streams("uav1", [(name, ZenohSource(key), key) for name, key in given])


@pytest.fixture
def follower_process(port: int) -> Iterator[subprocess.Popen[str]]:
    process = subprocess.Popen(
        [sys.executable, "-c", ENTRY, "follower", "--swarm", SWARM, "--id", "uav1",
         "--source", "cam=robot/camera", "--source", "robot/odometry", "-e",
         f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    yield process
    if process.poll() is None:
        process.kill()
    process.wait()


class Publisher:
    """The robot's two topics, a numbered sample on each every 20 ms until closed."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session, self._stop = session, threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        k = 0
        while not self._stop.wait(0.02):
            k += 1
            self._session.put("robot/camera", b"camera %d" % k)
            self._session.put("robot/odometry", b"odometry %d" % k)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()


def test_each_stream_is_a_member_of_one_robot_and_they_go_together(
        sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder,
        follower_process: subprocess.Popen[str]) -> None:
    members = {"uav1~cam": b"camera ", "uav1~robot_odometry": b"odometry "}
    publisher = Publisher(sessions.node(port))
    leader = LeaderNode(sessions.node(port), SWARM, every_record=True,
                        **recorder.callbacks())
    try:
        recorder.wait("both streams joined", lambda r: set(r.joins) == set(members))
        recorder.wait("both streams delivered", lambda r: all(
            r.count(member) >= 5 for member in members))
        with recorder.cond:
            for event in recorder.deliveries:  # each member carries its own topic
                assert event.payload.startswith(members[event.follower])
        eventually("stats name the robot", lambda: {
            (s.follower, s.robot) for s in leader.latest} == {
            (member, "uav1") for member in members})
        assert {s.as_dict()["robot"] for s in leader.latest} == {"uav1"}

        os.kill(follower_process.pid, signal.SIGKILL)  # the robot dies: its session too
        recorder.wait("both streams left", lambda r: set(r.leaves) == set(members))
    finally:
        leader.close()
        publisher.close()
    assert follower_process.wait() == -signal.SIGKILL
