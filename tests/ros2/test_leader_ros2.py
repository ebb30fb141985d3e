"""The leader as a ROS 2 participant, seen by a client nobody here wrote (zenoh-ros2-sdk
from PyPI, its message definitions given by the test): it lists the leader's node and
topics, receives each delivered update and the diagnostics, and its Path sets a
follower's control; bad ROS 2 input is counted and logged, never obeyed."""

from __future__ import annotations

import logging
import math
import queue
import time
from typing import Any

import pytest

from tests.transport.helpers import Recorder, Sessions, eventually
from wiswarm_zenoh.core import FollowerConfig, Waypoint
from wiswarm_zenoh.ros2 import Ros2Options
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

SWARM = "ros-swarm"  # not a ROS token: the namespace makes it one
NS = "/wiswarm/ros_swarm"
DOMAIN = 7
PAYLOAD = bytes(range(200)) * 5
TYPES = {f"{NS}/f1/update": "std_msgs/msg/UInt8MultiArray",
         f"{NS}/f2/update": "std_msgs/msg/UInt8MultiArray",
         f"{NS}/f1/waypoints": "nav_msgs/msg/Path",
         f"{NS}/f2/waypoints": "nav_msgs/msg/Path",
         "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray"}
WAIT_S = 15.0
DIAGNOSTICS = 10  # messages the client sends back at most


def test_a_third_party_client_lists_receives_and_steers(
        sessions: Sessions, port: int, recorder: Recorder, open_client: Any,
        caplog: pytest.LogCaptureFixture) -> None:
    sessions.router(port)
    controls: queue.SimpleQueue[list[Waypoint]] = queue.SimpleQueue()
    followers = [FollowerNode(sessions.node(port), SWARM, name, FollowerConfig(),
                              on_control=controls.put if name == "f1" else None,
                              sample_on_poll=lambda: PAYLOAD) for name in ("f1", "f2")]
    leader = LeaderNode(sessions.node(port), SWARM, bridge=Ros2Options(domain=DOMAIN),
                        **recorder.callbacks())
    try:
        client = open_client(port, DOMAIN, list(TYPES), [
            (f"{NS}/f1/update", TYPES[f"{NS}/f1/update"], 1),
            ("/diagnostics", TYPES["/diagnostics"], DIAGNOSTICS)])
        _, topics = client.next("topics")
        assert {name: types for name, types in topics if name in TYPES} == {
            name: [kind] for name, kind in TYPES.items()}
        _, info = client.next("info")
        assert info["publisher_count"] == 1
        assert [(p["node_namespace"], p["node_name"]) for p in info["publishers"]] == [
            (NS, "wiswarm_leader")]

        _, _, update = client.next("message", f"{NS}/f1/update")
        assert update["data"] == {"len": len(PAYLOAD), "head": list(PAYLOAD[:8])}
        for _ in range(DIAGNOSTICS):  # the first may come before any delivery
            _, _, diagnostics = client.next("message", "/diagnostics")
            by_name = {s["name"]: s for s in diagnostics["status"]}
            values = {v["key"]: float(v["value"]) for v in by_name[f"wiswarm/{SWARM}/f1"]["values"]}
            if values["deliveries"] >= 1:
                break
        assert set(by_name) == {f"wiswarm/{SWARM}/f1", f"wiswarm/{SWARM}/f2"}
        assert values["deliveries"] >= 1 and 0 < values["p_hat"] <= 1
        assert by_name[f"wiswarm/{SWARM}/f1"]["level"] == 0  # OK: a member

        now = time.time()
        plan = [(now + 1.0, 1.0, 2.0, 3.0), (now + 2.0, 4.0, 5.0, 3.5)]
        client.publish(f"{NS}/f1/waypoints", "nav_msgs/msg/Path", plan)
        assert next_plan(controls) == pytest.approx(flat(plan), abs=1e-6)

        bad = leader.bridge.bad_input  # type: ignore[union-attr]
        caplog.set_level(logging.WARNING)
        bad_inputs = [("std_msgs/msg/String", []),
                      ("nav_msgs/msg/Path", [(now + 3.0, math.nan, 0.0, 1.0)]),
                      ("nav_msgs/msg/Path", [(now + i, 1.0, 1.0, 1.0) for i in range(300)])]
        for count, (kind, poses) in enumerate(bad_inputs, 1):
            client.publish(f"{NS}/f1/waypoints", kind, poses)
            eventually(f"bad input {count} counted", lambda n=count: bad.total() == n)
        assert any(f"{DOMAIN}/wiswarm/ros_swarm/f1/waypoints/std_msgs::msg::dds_::String_"
                   in r.getMessage() for r in caplog.records)
        assert any("finite" in r.getMessage() for r in caplog.records)
        path_key = (f"{DOMAIN}/wiswarm/ros_swarm/f1/waypoints/nav_msgs::msg::dds_::Path_/"
                    "RIHS01_1957a5bb3cee5da65c4e52e52b65a93df227efce4c20f8458b36e73066ca334b")
        assert bad.counts[path_key] == 2  # logged once a second per key: counted each time
        while not controls.empty():  # what reached f1 before the last was refused
            controls.get()
        assert next_plan(controls) == pytest.approx(flat(plan), abs=1e-6)
    finally:
        leader.close()
        for follower in followers:
            follower.close()


def next_plan(controls: queue.SimpleQueue[list[Waypoint]]) -> list[float]:
    """The next non-empty control the follower obeyed, flat."""
    while not (entry := controls.get(timeout=WAIT_S)):
        pass
    return flat(entry)


def flat(plan: list[tuple[float, float, float, float]]) -> list[float]:
    return [value for waypoint in plan for value in waypoint]
