"""Newest-only push of a robot's ROS 2 topic, on real sessions over loopback: a camera
in rmw_zenoh's format -> ``wiswarm follower --system push --newest-only --ros2-topic``
(a ``spawn`` child, a client of the router) -> a ground subscriber on the topic a
``--ros2`` WiSwarm leader republishes it on, which gets the same type, bytes and source
times, put with blocking congestion control; an older sample is never sent. And the
mission's command line is exactly this follower."""

from __future__ import annotations

import multiprocessing
import threading
import time

import pytest
import zenoh

from tests.transport.helpers import WAIT, Samples, Sessions, wait_until_known
from wiswarm_zenoh.baselines import BaselineFollowerOptions, run_baseline_followers
from wiswarm_zenoh.cli import follower_command as follower_command_module
from wiswarm_zenoh.cli import main as cli_main
from wiswarm_zenoh.cli import nodes
from wiswarm_zenoh.experiments.mission import NEWEST_ONLY
from wiswarm_zenoh.experiments.ros2_air import AirCase, follower_command
from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.ros2.graph import ADMIN_SPACE, data_key, mangle, source_time_ns, topic_keys
from wiswarm_zenoh.ros2.messages import ros_type
from wiswarm_zenoh.ros2.newest_push import republished_topic
from wiswarm_zenoh.ros2.node import Ros2Node
from wiswarm_zenoh.ros2.topic_source import Ros2TopicSource
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

COMPRESSED = "sensor_msgs/msg/CompressedImage"
TOPIC = "/drone1/camera/image_raw/compressed"
DOMAIN = 3
SWARM = "air"
REPUBLISHED = f"/wiswarm/{SWARM}/d1{TOPIC}"
PATIENCE = 0.2  # seconds a sample may take to reach the ground before the next is sent


def _frame(k: int) -> bytes:
    """Any bytes: nothing on the way decodes them."""
    return k.to_bytes(4, "little") + bytes(range(200))


class PublisherToken:
    """``seen`` is set once a ROS 2 publisher of the republished topic is in the graph."""

    def __init__(self, session: zenoh.Session) -> None:
        self.seen = threading.Event()
        self._watch = session.liveliness().declare_subscriber(
            f"{ADMIN_SPACE}/{DOMAIN}/*/*/*/MP/*/*/*/{mangle(REPUBLISHED)}/*/*/*",
            lambda sample: self.seen.set(), history=True)


def test_the_newest_sample_goes_where_a_wiswarm_leader_republishes_it(
        sessions: Sessions, port: int) -> None:
    sessions.router(port)
    kind = ros_type(COMPRESSED)
    ground_session = sessions.node(port, "client")
    ground = Samples(ground_session, topic_keys(DOMAIN, REPUBLISHED))
    in_graph = PublisherToken(ground_session)
    camera_session = sessions.node(port)
    camera = Ros2Node(camera_session, "camera", "/drone1", DOMAIN).publisher_of(TOPIC, kind)
    stamps: dict[int, int] = {}

    def publish(k: int, stamp: int | None = None) -> None:
        stamps[k] = time.time_ns() if stamp is None else stamp
        camera.publish_cdr(_frame(k), stamps[k])

    def received() -> list[int]:
        with ground.cond:
            return [int.from_bytes(s.payload.to_bytes()[:4], "little") for s in ground.samples]

    spec = SessionSpec(mode="client", connect=(f"tcp/127.0.0.1:{port}",),
                       multicast_scouting=False)
    options = BaselineFollowerOptions(SWARM, ("d1",), "push", 100.0, newest_only=True,
                                      source=Ros2TopicSource(TOPIC, DOMAIN))
    with Children(multiprocessing.get_context("spawn")) as children:
        children.start("follower", run_baseline_followers, spec, options)
        wait_until_known(camera_session, data_key(DOMAIN, TOPIC, kind))
        # The follower's publisher is made on its first sample, and a put made before
        # its session knows of the ground's subscriber reaches nobody: samples go one
        # at a time until one gets through.
        first = 0
        while not received():
            first += 1
            assert first < 50, "no sample reached the ground"
            publish(first)
            with ground.cond:
                ground.cond.wait_for(lambda: bool(ground.samples), PATIENCE)
        assert in_graph.seen.wait(WAIT), "no ROS 2 publisher of the republished topic"
        last = first + 21
        for k in range(first + 1, last):  # a burst: what waits is replaced by what comes
            publish(k)
        publish(0, stamps[last - 1] - 1)  # older than one offered before: never sent
        publish(last)
        ground.wait("the burst's last sample", lambda _: received()[-1:] == [last])
    got = received()
    assert 0 not in got and got == sorted(got), got
    with ground.cond:
        samples = list(ground.samples)
    for k, sample in zip(got, samples, strict=True):
        assert str(sample.key_expr) == data_key(DOMAIN, REPUBLISHED, kind)
        assert sample.payload.to_bytes() == _frame(k)
        assert sample.attachment is not None
        assert source_time_ns(sample.attachment.to_bytes()) == stamps[k]
        assert sample.congestion_control == zenoh.CongestionControl.BLOCK


def test_the_missions_newest_command_line_is_this_follower(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """``follower_command`` + ``NEWEST_ONLY``, as the mission starts robot 1's follower:
    its options, and that the ground's topic for it is the republished one."""
    got: list[tuple[SessionSpec, BaselineFollowerOptions]] = []
    monkeypatch.setattr(follower_command_module, "run_baseline_followers",
                        lambda spec, options, stop, ready: got.append((spec, options)))
    monkeypatch.setattr(cli_main, "every_command", lambda: (nodes.register,))
    assert cli_main.main([*follower_command(1), *NEWEST_ONLY]) == 0
    [(spec, options)] = got
    assert (options.system, options.newest_only, options.congestion) == ("push", True, "block")
    assert options.source is not None and options.follower_ids == ("d1",)
    assert spec.mode == "client"
    assert republished_topic(options.swarm, "d1", options.source.topic) == \
        AirCase("wiswarm", 1).topic(1)
