"""Every script in ``examples/`` runs against a real router: a follower's bytes reach the
printing leader, the observer prints the swarm's stats, the steering leader's waypoints
reach the follower; each ends cleanly at Ctrl-C (SIGINT) or at its --duration."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from wiswarm_zenoh.transport import SessionSpec, free_tcp_port

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
WAIT = 30.0  # seconds: generous (a busy machine, a Python start per example)


class Example:
    """One example as a user starts it, its output gathered line by line."""

    def __init__(self, script: str, port: int, *flags: str) -> None:
        self.lines: list[str] = []
        self._cond = threading.Condition()
        self.process = subprocess.Popen(
            [sys.executable, str(EXAMPLES / script), "-e", f"tcp/127.0.0.1:{port}",
             "-l", "tcp/127.0.0.1:0", "--no-multicast-scouting", "--swarm", "examples",
             *flags], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            with self._cond:
                self.lines.append(line.rstrip("\n"))
                self._cond.notify_all()

    def wait_for(self, pattern: str) -> str:
        """The first line matching ``pattern``, once it is printed."""
        def found() -> str | None:
            return next((line for line in self.lines if re.search(pattern, line)), None)
        with self._cond:
            assert self._cond.wait_for(found, WAIT), f"no {pattern!r} in {self.lines}"
            return found() or ""

    def stop(self) -> None:
        """Ctrl-C, as a user stops it: a clean exit."""
        self.process.send_signal(signal.SIGINT)
        self.ends()

    def ends(self) -> None:
        assert self.process.wait(WAIT) == 0, self.lines
        self._reader.join(WAIT)


@pytest.fixture
def port() -> Iterator[int]:
    """A router on loopback, as ``wiswarm router`` would be."""
    port = free_tcp_port()
    with SessionSpec.loopback("router", port).open():
        yield port


def stopped(*examples: Example) -> None:
    for example in examples:
        if example.process.poll() is None:
            example.process.kill()
            example.process.wait()


def test_a_follower_s_bytes_reach_the_printing_leader_and_the_observer(port: int) -> None:
    follower = Example("follower_bytes.py", port, "--id", "uav1", "--rate", "50")
    leader = Example("leader_print.py", port)
    observer = Example("observer.py", port, "--deliveries")
    try:
        leader.wait_for(r"^uav1 joined")
        leader.wait_for(r"^uav1: \d+ bytes, [\d.]+ ms old: b'uav1 reading \d+")
        observer.wait_for(r"^leader .*: 1 followers, \d+ polls/s")
        observer.wait_for(r"^  uav1: AoI [\d.]+ ms, [1-9]\d* deliveries")
        observer.wait_for(r"^  uav1: delivered")
        for example in (observer, follower, leader):
            example.stop()
        assert re.search(r"^[1-9]\d* polls answered$", follower.lines[-1])
    finally:
        stopped(follower, leader, observer)


def test_the_steering_leader_s_waypoints_reach_the_follower(port: int) -> None:
    follower = Example("follower_bytes.py", port, "--id", "uav2")
    leader = Example("leader_waypoints.py", port, "--period", "0.2")
    try:
        line = follower.wait_for(r"^waypoints: \[\(")
        _, x, y, z = map(float, re.findall(r"-?[\d.]+(?:e-?\d+)?", line))
        assert (round(x**2 + y**2), z) == (400, 10.0)  # on the circle of radius 20
        leader.stop()
        follower.stop()
    finally:
        stopped(follower, leader)


def test_an_example_stops_at_its_duration(port: int) -> None:
    observer = Example("observer.py", port, "--duration", "0.5")
    try:
        observer.ends()
        assert observer.lines[0].startswith("watching swarm 'examples'")
    finally:
        stopped(observer)


def test_every_example_is_run_here() -> None:
    source = Path(__file__).read_text()
    scripts = {p.name for p in EXAMPLES.glob("*.py")} - {"common.py"}
    assert scripts == set(re.findall(r'Example\("(\w+\.py)"', source))


def test_the_camera_is_taken_by_a_follower_as_a_ros2_topic(port: int) -> None:
    """The camera stands in for a robot's: a ``--ros2-topic`` follower finds its type
    from its tokens and serves its frames."""
    from wiswarm_zenoh import Follower
    from wiswarm_zenoh.ros2 import Ros2TopicSource

    topic = "/drone9/camera/image_raw/compressed"
    camera = Example("camera_ros2.py", port, "--topic", topic, "--rate", "50",
                     "--bytes", "2000")
    robot = SessionSpec.loopback("peer", connect_ports=[port]).open()
    follower = Follower(robot, "examples", "d9", source=Ros2TopicSource(topic))
    try:
        camera.wait_for(r"^camera /drone9/camera: 2000-byte frames at 50 Hz")
        feed = follower.source
        assert feed is not None
        deadline = time.monotonic() + WAIT
        while feed.samples < 5:  # a counter no callback announces
            assert time.monotonic() < deadline, "the follower served no frame"
            time.sleep(0.01)
        assert feed.type is not None and feed.type.name == "sensor_msgs/msg/CompressedImage"
        camera.stop()
        assert re.search(r"^[1-9]\d* frames taken$", camera.lines[-1])
    finally:
        follower.close()
        robot.close()
        stopped(camera)
