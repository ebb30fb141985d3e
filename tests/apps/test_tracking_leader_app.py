"""The leader's vision thread: freshest frame per UAV, round robin, plans in the UAV's
clock; and the AoI bookkeeping of frames arriving at the leader."""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np
import pytest

from wiswarm_apps.tracking.frames import Frame, encode_frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.leader_app import Arrival, CarEstimate, VisionLoop
from wiswarm_apps.tracking.reception import Reception
from wiswarm_apps.tracking.render import Renderer
from wiswarm_apps.tracking.report import aoi_series
from wiswarm_apps.tracking.world import World, WorldConfig

WORLD = World(WorldConfig(n_cars=2, seed=11, duration_s=60))
RENDERER = Renderer(WORLD)
CAMERA = CameraModel()


class RecordingSink:
    """The ControlSink the vision thread talks to, keeping what it was told."""

    def __init__(self, expected: int) -> None:
        self.plans: list[tuple[str, list[tuple[float, ...]]]] = []
        self.urgencies: list[tuple[str, float]] = []
        self._expected = expected
        self.done = threading.Event()
        self.handled = threading.Semaphore(0)  # one release per frame that gave a plan

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        self.plans.append((follower, [tuple(w) for w in waypoints]))

    def observe_urgency(self, follower: str, urgency: float) -> float:
        self.urgencies.append((follower, urgency))
        self.handled.release()
        if len(self.urgencies) >= self._expected:
            self.done.set()
        return urgency


def frame_over_car(car: int, t: float) -> bytes:
    x, y = WORLD.car_position(car, t)
    pose = Pose(x + 0.2, y - 0.1, 2.0, 0.3)
    return encode_frame(Frame(t, pose, CAMERA, RENDERER.frame(pose, CAMERA, t)))


def _process(vision: VisionLoop, sink: RecordingSink) -> None:
    """Run the vision thread until the sink has every plan it expects."""
    vision.start(sink)
    try:
        assert sink.done.wait(10.0)
    finally:
        vision.stop()


def test_only_the_freshest_frame_of_each_uav_is_processed_round_robin() -> None:
    vision = VisionLoop({"a": 0, "b": 1}, WORLD.arena, camera=CAMERA)
    for t in (1.0, 1.1, 1.2):
        vision.submit("a", Arrival(frame_over_car(0, t), t, t + 0.01))
    vision.submit("b", Arrival(frame_over_car(1, 1.0), 1.0, 1.01))
    sink = RecordingSink(expected=2)
    _process(vision, sink)
    stats = vision.stats()
    assert (stats["a"].arrivals, stats["a"].processed, stats["a"].superseded) == (3, 1, 2)
    assert (stats["b"].processed, stats["b"].detections) == (1, 1)
    assert sorted(uav for uav, _ in sink.plans) == ["a", "b"]
    plan_a = stats["a"].plan
    assert plan_a is not None and plan_a.last_seen_t == pytest.approx(1.2)  # the freshest
    true_x, true_y = WORLD.car_position(0, 1.2)
    assert plan_a.car_xy == pytest.approx((true_x, true_y), abs=0.05)


def test_waypoints_are_stamped_in_the_uav_clock() -> None:
    """The leader's clock runs 100 s ahead of the UAV's: the plan still starts at the
    UAV's present, not the leader's."""
    offset, processing_at = 100.0, 1.0 + 100.0 + 0.02
    vision = VisionLoop({"a": 0}, WORLD.arena, camera=CAMERA, clock=lambda: processing_at)
    vision.submit("a", Arrival(frame_over_car(0, 1.0), 1.0 + offset, 1.01 + offset))
    sink = RecordingSink(expected=1)
    _process(vision, sink)
    waypoints = sink.plans[0][1]
    assert waypoints[0][0] == pytest.approx(1.02)
    assert all(WORLD.arena.contains(w[1], w[2]) for w in waypoints)


def test_each_sighting_is_an_estimate_stamped_on_the_leaders_clock() -> None:
    """The frame at 1.2 s comes after the one at 1.3 s: it is older, so no estimate."""
    offset = 100.0  # the leader's clock ahead of the UAV's
    vision = VisionLoop({"a": 0}, WORLD.arena, camera=CAMERA)
    estimates: list[CarEstimate] = []
    sink = RecordingSink(expected=3)
    vision.start(sink, estimates.append)
    try:
        for t in (1.0, 1.3, 1.2):  # one at a time: none replaces another unprocessed
            vision.submit("a", Arrival(frame_over_car(0, t), t + offset, t + offset + 0.01))
            assert sink.handled.acquire(timeout=10.0)
    finally:
        vision.stop()
    assert [(e.uav, e.car, e.at) for e in estimates] == [("a", 0, 1.0 + offset),
                                                           ("a", 0, 1.3 + offset)]
    assert estimates[-1].xy == pytest.approx(WORLD.car_position(0, 1.3), abs=0.05)


def test_frames_from_a_uav_without_a_car_are_refused() -> None:
    vision = VisionLoop({"a": 0}, WORLD.arena)
    vision.submit("stranger", Arrival(b"x", 1.0, 1.0))
    assert vision.bad_input.counts["stranger"] == 1
    assert set(vision.stats()) == {"a"}


def test_aoi_counts_only_the_window_and_matches_the_sampled_sawtooth() -> None:
    vision = VisionLoop({"a": 0}, WORLD.arena)  # not started: frames just wait
    reception = Reception(["a"], vision)
    reception.receive("a", b"early", 9.0, 9.5)  # before the window: not counted
    reception.open_window(10.0, 12.0)
    rng = np.random.default_rng(3)
    t = 10.0
    while t < 12.0:
        generated = t - float(rng.uniform(0.0, 0.004))  # steps are longer: always fresher
        reception.receive("a", b"f", generated, t)
        t += float(rng.uniform(0.005, 0.05))
    reception.receive("a", b"late", 12.2, 12.3)  # after the window: not counted
    summary = reception.summary(12.0)["a"]
    times, ages = aoi_series(reception.rows(), "a", 10.0, 12.0, step=1e-4)
    assert summary.mean_aoi_s == pytest.approx(float(ages.mean()), abs=5e-4)
    assert summary.p95_aoi_s == pytest.approx(float(np.percentile(ages, 95)), abs=1e-3)
    assert summary.deliveries == len(reception.rows())
    assert vision.stats()["a"].arrivals == summary.deliveries  # counted in the window only
    assert len(times) == len(ages) == 20000
