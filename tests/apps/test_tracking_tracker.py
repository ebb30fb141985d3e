"""Leader-side planning: velocity estimate, linear extrapolation, urgency, lost car."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wiswarm_apps.tracking.frames import Frame
from wiswarm_apps.tracking.geometry import Arena, CameraModel, Pose
from wiswarm_apps.tracking.metrics import UavMetrics
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.tracker import CarTracker, TrackerConfig
from wiswarm_apps.tracking.uav import VirtualUAV
from wiswarm_apps.tracking.vision import Detection, MarkerDetector
from wiswarm_apps.tracking.world import World, WorldConfig

CAMERA = CameraModel()
BLANK = np.zeros((224, 224), np.uint8)


def frame_at(t: float, uav_x: float = 5.0, uav_y: float = 5.0) -> Frame:
    return Frame(t=t, pose=Pose(uav_x, uav_y, 2.0), camera=CAMERA, pixels=BLANK)


def seen(x: float, y: float) -> Detection:
    return Detection(marker_id=0, u=0.0, v=0.0, x=x, y=y, side_px=30.0)


def test_constant_velocity_car_is_extrapolated_along_its_line() -> None:
    tracker = CarTracker(Arena(), TrackerConfig(altitude_m=2.5, horizon_s=1.0, step_s=0.25))
    for k in range(10):
        t = 10.0 + 0.05 * k
        plan = tracker.update(frame_at(t), seen(3.0 + 0.4 * (t - 10), 4.0 - 0.3 * (t - 10)),
                              now=t + 0.02)
    assert plan.car_velocity == pytest.approx((0.4, -0.3))
    assert plan.urgency == pytest.approx(0.5)  # the UAV stands still: |v_car|
    times = [w[0] for w in plan.waypoints]
    assert times == pytest.approx([10.47, 10.72, 10.97, 11.22, 11.47])
    for t, x, y, z in plan.waypoints:
        assert (x, y, z) == pytest.approx((3.0 + 0.4 * (t - 10), 4.0 - 0.3 * (t - 10), 2.5))


def test_noisy_sightings_give_a_close_velocity() -> None:
    rng = np.random.default_rng(3)
    tracker = CarTracker(Arena())
    for k in range(30):
        t = 0.02 * k
        plan = tracker.update(frame_at(t), seen(5 + 0.5 * t + rng.normal(0, 0.005),
                                                5 + rng.normal(0, 0.005)), now=t)
    assert math.dist(plan.car_velocity, (0.5, 0.0)) < 0.1


def test_urgency_is_the_relative_speed_with_a_floor() -> None:
    tracker = CarTracker(Arena(), TrackerConfig(min_urgency=0.05))
    for k in range(10):
        t = 0.05 * k
        plan = tracker.update(frame_at(t, uav_x=5 + 0.3 * t), seen(5 + 0.3 * t, 5.0), now=t)
    assert plan.urgency == pytest.approx(0.05)  # same velocity: relative speed 0
    for k in range(10, 30):
        t = 0.05 * k
        plan = tracker.update(frame_at(t, uav_x=5.0), seen(5 + 0.3 * t, 5.0), now=t)
    assert plan.urgency == pytest.approx(0.3, abs=0.01)


def test_lost_car_keeps_the_last_plan_and_counts_misses() -> None:
    tracker = CarTracker(Arena())
    assert tracker.plan.waypoints == ()
    kept = tracker.update(frame_at(1.0), seen(4.0, 4.0), now=1.0)
    for k in range(3):
        plan = tracker.update(frame_at(1.1 + k * 0.1), None, now=1.5)
    assert plan.waypoints == kept.waypoints
    assert (plan.car_seen, plan.missed_frames, plan.last_seen_t) == (False, 3, 1.0)
    back = tracker.update(frame_at(2.0), seen(4.0, 4.0), now=2.0)
    assert (back.car_seen, back.missed_frames) == (True, 0)


def test_stale_frames_change_nothing() -> None:
    tracker = CarTracker(Arena())
    plan = tracker.update(frame_at(2.0), seen(4.0, 4.0), now=2.0)
    assert tracker.update(frame_at(1.0), seen(9.0, 9.0), now=2.1) is plan


def test_extrapolation_stays_inside_the_arena() -> None:
    tracker = CarTracker(Arena(), TrackerConfig(horizon_s=3.0))
    tracker.update(frame_at(0.0), seen(19.5, 9.5), now=0.0)
    plan = tracker.update(frame_at(0.2), seen(19.9, 9.9), now=0.2)  # 2 m/s to the corner
    assert all(0 <= x <= 20 and 0 <= y <= 10 for _, x, y, _ in plan.waypoints)
    assert plan.waypoints[-1][1:3] == (20.0, 10.0)


def test_closed_loop_keeps_a_moving_car_in_view() -> None:
    """Render, detect and plan every 20 ms with 40 ms of control latency for 20 s: the
    loop itself (no network) keeps the car in view and the error small."""
    world = World(WorldConfig(seed=31, n_cars=2, duration_s=30))
    x, y = world.car_position(1, 0.0)
    uav = VirtualUAV("u1", Pose(x, y, 2.0, 0.7), Renderer(world), start_time=0.0)
    tracker, detector, metrics = CarTracker(world.arena), MarkerDetector(), UavMetrics("u1",
                                                                                        CAMERA)
    pending: list[tuple[float, tuple[tuple[float, float, float, float], ...]]] = []
    for k in range(1000):
        t = 0.02 * k
        while pending and pending[0][0] <= t:
            uav.set_waypoints(pending.pop(0)[1])
            metrics.control_received(t - 0.04)
        frame = uav.capture(t)
        plan = tracker.update(frame, detector.locate(frame, 1), now=t + 0.04)
        if plan.car_seen:
            pending.append((t + 0.04, plan.waypoints))
        metrics.record(t, uav.pose(t), world.car_position(1, t))
    summary = metrics.summary()
    assert summary.in_view_share == 1.0
    assert summary.mean_tracking_error_m < 0.1
