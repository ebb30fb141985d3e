"""The virtual UAV flies its plan at bounded speed and stamps frames with its pose."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.uav import VirtualUAV
from wiswarm_apps.tracking.vision import MarkerDetector
from wiswarm_apps.tracking.world import World, WorldConfig

WORLD = World(WorldConfig(seed=21, duration_s=60))
RENDERER = Renderer(WORLD)


def make_uav(max_speed: float = 2.0) -> VirtualUAV:
    return VirtualUAV("uav-0", Pose(5.0, 5.0, 2.0, 0.5), RENDERER, start_time=100.0,
                      max_speed_mps=max_speed, world_epoch=100.0)


def distance(pose: Pose, x: float, y: float, z: float) -> float:
    return math.dist((pose.x, pose.y, pose.z), (x, y, z))


def test_reaches_each_reachable_waypoint_at_its_time() -> None:
    uav = make_uav()
    plan = [(101.0, 6.0, 5.0, 2.0), (102.0, 6.0, 6.5, 2.5), (103.0, 7.0, 6.5, 2.5)]
    assert uav.set_waypoints(plan)
    for t, x, y, z in plan:
        assert distance(uav.pose(t), x, y, z) < 0.02


def test_speed_is_bounded_when_a_waypoint_is_out_of_reach() -> None:
    uav = make_uav(max_speed=1.0)
    uav.set_waypoints([(100.5, 15.0, 5.0, 2.0)])  # 10 m in 0.5 s: too fast
    positions = [uav.pose(100.0 + k * 0.1) for k in range(1, 41)]
    steps = [math.dist((a.x, a.y), (b.x, b.y)) for a, b in itertools.pairwise(positions)]
    assert max(steps) <= 1.0 * 0.1 + 1e-9
    assert positions[-1].x == pytest.approx(9.0, abs=1e-6)  # 4 s at 1 m/s, still going
    assert uav.pose(120.0).x == pytest.approx(15.0)  # then holds at the last waypoint
    assert uav.pose(125.0).x == pytest.approx(15.0)


def test_rejected_plan_keeps_the_last_safe_one() -> None:
    uav = make_uav()
    assert uav.set_waypoints([(101.0, 6.0, 5.0, 2.0)])
    assert not uav.set_waypoints([(101.0, math.nan, 5.0, 2.0)])
    assert not uav.set_waypoints([(101.0, 30.0, 5.0, 2.0)])
    assert uav.guard.rejected == 2
    assert distance(uav.pose(102.0), 6.0, 5.0, 2.0) < 1e-9


def test_holds_still_without_a_plan_and_when_the_clock_steps_back() -> None:
    uav = make_uav()
    assert uav.pose(110.0) == Pose(5.0, 5.0, 2.0, 0.5)
    uav.set_waypoints([(111.0, 7.0, 5.0, 2.0)])
    at = uav.pose(111.0)
    assert uav.pose(105.0) == at


def test_frame_is_stamped_with_the_pose_at_capture_and_sees_the_world() -> None:
    uav = make_uav()
    x, y = WORLD.car_position(0, 4.0)
    uav.set_waypoints([(103.5, x, y, 2.0)])  # 5.9 m away: reachable at 2 m/s
    frame = uav.capture(104.0)
    assert frame.t == 104.0
    assert frame.pose == uav.pose(104.0)
    assert distance(frame.pose, x, y, 2.0) < 1e-6
    assert frame.pixels.shape == (224, 224)
    np.testing.assert_array_equal(frame.pixels, RENDERER.frame(frame.pose, uav.camera, 4.0))
    assert MarkerDetector().locate(frame, 0) is not None  # world time = now - epoch


def test_flight_camera_makes_160_pixel_frames() -> None:
    uav = VirtualUAV("u", Pose(5, 5, 2), RENDERER, 0.0, camera=CameraModel(width=160,
                                                                              height=160))
    assert uav.capture(1.0).pixels.shape == (160, 160)
