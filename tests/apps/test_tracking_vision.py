"""Rendering plus ArUco detection: the car is found where it is, to well under 5 cm."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wiswarm_apps.tracking.frames import Frame
from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.render import OUTSIDE_GRAY, Renderer
from wiswarm_apps.tracking.vision import MarkerDetector
from wiswarm_apps.tracking.world import World, WorldConfig

WORLD = World(WorldConfig(seed=11, n_cars=4, duration_s=120))
RENDERER = Renderer(WORLD)
DETECTOR = MarkerDetector()
CAMERAS = [CameraModel(), CameraModel(width=160, height=160)]


@pytest.mark.parametrize("camera", CAMERAS, ids=["224", "160"])
@pytest.mark.parametrize(
    ("t", "dx", "dy", "altitude", "yaw"),
    [
        (0.0, 0.0, 0.0, 2.0, 0.0),
        (7.3, 0.3, -0.2, 2.0, 0.6),
        (21.0, -0.4, 0.25, 2.5, -2.2),
        (33.3, 0.15, 0.35, 1.5, math.pi),
        (58.9, -0.5, -0.3, 3.0, 1.3),
    ],
)
def test_detected_marker_maps_to_the_car_within_5_cm(
    camera: CameraModel, t: float, dx: float, dy: float, altitude: float, yaw: float
) -> None:
    for car in range(WORLD.n_cars):
        x, y = WORLD.car_position(car, t)
        pose = Pose(x + dx, y + dy, altitude, yaw)
        frame = Frame(t=t, pose=pose, camera=camera, pixels=RENDERER.frame(pose, camera, t))
        detection = DETECTOR.locate(frame, car)
        assert detection is not None, f"car {car} not found from {pose}"
        assert math.hypot(detection.x - x, detection.y - y) < 0.05
        u, v = camera.world_to_pixel(pose, x, y)
        assert math.hypot(detection.u - u, detection.v - v) < 2.0


def test_only_the_assigned_marker_is_returned() -> None:
    x, y = WORLD.car_position(0, 0.0)
    pose = Pose(x, y, 2.0)
    frame = Frame(0.0, pose, CAMERAS[0], RENDERER.frame(pose, CAMERAS[0], 0.0))
    assert DETECTOR.locate(frame, 0) is not None
    assert DETECTOR.locate(frame, 3) is None


def test_bare_ground_shows_no_markers() -> None:
    rng = np.random.default_rng(0)
    empty = World(WorldConfig(seed=11, n_cars=1, duration_s=10))
    renderer = Renderer(empty)
    car_x, car_y = empty.car_position(0, 0.0)
    seen = 0
    for _ in range(40):
        x, y = rng.uniform([1, 1], [19, 9])
        if math.hypot(x - car_x, y - car_y) < 2.5:
            continue
        pose = Pose(float(x), float(y), float(rng.uniform(1.5, 3.0)), float(rng.uniform(-3, 3)))
        seen += len(DETECTOR.detect(renderer.frame(pose, CAMERAS[0], 0.0)))
    assert seen == 0


def test_frame_is_uint8_of_the_camera_size_and_grey_beyond_the_arena() -> None:
    camera = CameraModel(width=160, height=160)
    image = RENDERER.frame(Pose(-5.0, -5.0, 2.0), camera, 0.0)
    assert image.shape == (160, 160) and image.dtype == np.uint8
    assert np.all(image == OUTSIDE_GRAY)
    inside = RENDERER.frame(Pose(10.0, 5.0, 2.0), camera, 0.0)
    assert inside.std() > 3.0  # textured ground


def test_rendering_is_deterministic_and_tracks_world_time() -> None:
    x, y = WORLD.car_position(1, 5.0)
    pose = Pose(x, y, 2.0, 0.3)
    first = RENDERER.frame(pose, CAMERAS[0], 5.0)
    np.testing.assert_array_equal(first, Renderer(WORLD).frame(pose, CAMERAS[0], 5.0))
    assert np.any(first != RENDERER.frame(pose, CAMERAS[0], 6.0))


def test_overview_covers_the_arena() -> None:
    image = RENDERER.overview(0.0, resolution_m=0.05)
    assert image.shape == (200, 400)


@pytest.mark.parametrize("yaw", [0.0, 0.9, -2.4])
def test_pixel_world_mapping_round_trips(yaw: float) -> None:
    camera, pose = CAMERAS[0], Pose(4.0, 6.0, 2.2, yaw)
    assert camera.pixel_to_world(pose, 111.5, 111.5) == pytest.approx((4.0, 6.0))
    u, v = camera.world_to_pixel(pose, 4.3, 5.8)
    assert camera.pixel_to_world(pose, u, v) == pytest.approx((4.3, 5.8))
    # image up is the heading
    hx, hy = camera.pixel_to_world(pose, 111.5, 0.0)
    assert math.atan2(hy - 6.0, hx - 4.0) == pytest.approx(yaw)
