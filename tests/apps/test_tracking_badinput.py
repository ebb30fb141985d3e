"""Bad frames at the leader and bad waypoints at a UAV, over real Zenoh on loopback:
each is rejected with a logged reason, counted, and nothing stops working."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable

import msgpack
import numpy as np
import pytest

from wiswarm_apps.tracking.frames import Frame, encode_frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.leader_app import VisionLoop
from wiswarm_apps.tracking.reception import Reception
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.uav_app import SYSTEMS, System, UavOptions, UavRuntime
from wiswarm_apps.tracking.world import World, WorldConfig
from wiswarm_zenoh.core.messages import VERSION
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SessionSpec, SwarmKeys
from wiswarm_zenoh.transport.badinput import BadInputLog

SWARM = "badinput"
WORLD = WorldConfig(n_cars=2, seed=5, duration_s=120)
RENDERER = Renderer(World(WORLD))
Wait = Callable[..., bool]


def bad_frames() -> list[tuple[bytes, str]]:
    """(payload, words of the logged reason) for each kind of bad frame."""
    small = CameraModel(width=160, height=160)
    wrong_size = encode_frame(Frame(1.0, Pose(5, 5, 2), small, np.zeros((160, 160), np.uint8)))
    short_pixels = msgpack.packb({"v": 1, "t": 1.0, "pose": [5.0, 5.0, 2.0, 0.0], "fov": 60.0,
                                  "w": 224, "h": 224, "px": b"\x00" * 1000})
    return [(b"\xc1 not msgpack", "undecodable"), (wrong_size, "differs from the expected"),
            (short_pixels, "px must be 50176 bytes")]


def test_bad_frames_are_rejected_with_a_reason_and_tracking_goes_on(
    node_spec: SessionSpec, wait: Wait, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING)
    vision = VisionLoop({"uav0": 0, "rogue": 1}, WORLD.arena, camera=CameraModel())
    vision.bad_input = BadInputLog(logging.getLogger("test.vision"), interval=0.0)
    reception = Reception(["uav0", "rogue"], vision)
    epoch = time.time()
    reception.open_window(epoch, epoch + 60)
    options = UavOptions(swarm=SWARM, uav="uav0", car=0, world=WORLD)
    with node_spec.open() as leader_s, node_spec.open() as uav_s, node_spec.open() as rogue_s, \
            LeaderNode(leader_s, SWARM, on_delivery=reception.on_delivered) as leader, \
            FollowerNode(rogue_s, SWARM, "rogue") as rogue:
        vision.start(leader)
        uav = UavRuntime(uav_s, options, RENDERER, epoch)
        try:
            for count, (payload, _reason) in enumerate(bad_frames(), start=1):
                rogue.offer(payload)
                assert wait(lambda n=count: vision.stats()["rogue"].bad_frames == n)
            plans = vision.stats()["uav0"].plans_sent
            assert wait(lambda: vision.stats()["uav0"].plans_sent > plans + 20)
            assert wait(lambda: uav.vehicle.guard.accepted > 20)
        finally:
            uav.close()
            vision.stop()
    rogue_stats = vision.stats()["rogue"]
    assert (rogue_stats.processed, rogue_stats.plans_sent) == (0, 0)
    logged = [r.getMessage() for r in caplog.records if r.name == "test.vision"]
    for _payload, reason in bad_frames():
        assert any("rogue" in line and reason in line for line in logged), (reason, logged)


def control(seq: int, entries: dict[str, list[list[float]]]) -> bytes:
    """A control message as raw msgpack (the encoder would refuse a NaN)."""
    return bytes(msgpack.packb({"v": VERSION, "t": "control", "seq": seq, "lt": time.time(),
                                "e": 0, "entries": entries}))


@pytest.mark.parametrize("system", SYSTEMS)
def test_bad_waypoints_are_rejected_and_the_uav_holds_its_last_safe_plan(
    node_spec: SessionSpec, wait: Wait, caplog: pytest.LogCaptureFixture, system: System
) -> None:
    caplog.set_level(logging.WARNING)
    options = UavOptions(swarm=SWARM, uav="uav0", car=0, world=WORLD, system=system)
    start = options.start_pose()
    with node_spec.open() as uav_s, node_spec.open() as leader_s, \
            leader_s.declare_publisher(SwarmKeys(SWARM).control) as publisher:
        uav = UavRuntime(uav_s, options, RENDERER, time.time())
        guard = uav.vehicle.guard
        try:
            assert wait(lambda: publisher.matching_status.matching)
            safe = (time.time() + 0.3, start.x + 0.4, start.y, 2.0)
            publisher.put(control(1, {"uav0": [list(safe)]}))
            assert wait(lambda: guard.accepted == 1)
            publisher.put(control(2, {"uav0": [[time.time() + 0.3, 25.0, start.y, 2.0]]}))
            assert wait(lambda: guard.rejected == 1)
            publisher.put(control(3, {"uav0": [[time.time() + 0.3, math.nan, 5.0, 2.0]]}))
            assert wait(lambda: uav.result().counters["bad_control"] == 1)
            assert guard.plan == (safe,)
            assert (guard.accepted, guard.rejected) == (1, 1)

            def holds_safe_waypoint() -> bool:
                pose = uav.vehicle.pose_at(time.time())
                return pose is not None and math.dist((pose.x, pose.y), safe[1:3]) < 0.01

            assert wait(holds_safe_waypoint)
        finally:
            uav.close()
    messages = " | ".join(r.getMessage() for r in caplog.records)
    assert "outside the 20.0 x 10.0 m arena" in messages
    assert "bad input from wiswarm/badinput/control" in messages
    assert "finite numbers" in messages
