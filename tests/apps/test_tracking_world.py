"""The world: deterministic from its seed, cars inside the arena at bounded speed."""

from __future__ import annotations

import numpy as np
import pytest

from wiswarm_apps.tracking.geometry import Arena
from wiswarm_apps.tracking.world import Motion, World, WorldConfig

TIMES = np.linspace(0.0, 300.0, 3001)


def trajectory(world: World) -> np.ndarray:
    return np.stack([world.car_positions(t) for t in TIMES])


@pytest.mark.parametrize("motion", ["random_walk", "polygon"])
def test_same_seed_same_world_other_seed_other_world(motion: Motion) -> None:
    a = trajectory(World(WorldConfig(seed=7, motion=motion, duration_s=300)))
    b = trajectory(World(WorldConfig(seed=7, motion=motion, duration_s=300)))
    c = trajectory(World(WorldConfig(seed=8, motion=motion, duration_s=300)))
    np.testing.assert_array_equal(a, b)
    assert np.max(np.abs(a - c)) > 1.0


@pytest.mark.parametrize("motion", ["random_walk", "polygon"])
def test_cars_stay_inside_and_respect_the_speed_limit(motion: Motion) -> None:
    config = WorldConfig(seed=3, motion=motion, n_cars=6, duration_s=300)
    world = World(config)
    path = trajectory(world)  # (time, car, xy)
    half = config.tag_size_m / 2
    assert np.all(path[..., 0] >= half) and np.all(path[..., 0] <= config.arena.width_m - half)
    assert np.all(path[..., 1] >= half) and np.all(path[..., 1] <= config.arena.height_m - half)
    speeds = np.linalg.norm(np.diff(path, axis=0), axis=2) / np.diff(TIMES)[:, None]
    assert speeds.max() <= config.max_speed_mps + 1e-6
    assert speeds.mean() > config.min_speed_mps / 2  # the cars do move


@pytest.mark.parametrize("motion", ["random_walk", "polygon"])
def test_separate_cars_never_overlap_but_shared_ones_roam_the_arena(motion: Motion) -> None:
    config = WorldConfig(seed=5, motion=motion, n_cars=6, duration_s=300)
    path = trajectory(World(config))
    gaps = [np.linalg.norm(path[:, i] - path[:, j], axis=1).min()
            for i in range(6) for j in range(i)]
    assert min(gaps) > config.tag_size_m * 1.4  # rotated tags cannot touch
    shared = trajectory(World(WorldConfig(seed=5, motion=motion, separate=False, duration_s=300)))
    spans = shared.max(axis=0) - shared.min(axis=0)  # (car, xy)
    assert spans[:, 0].max() > config.arena.width_m / 3  # wider than a 3-column grid cell


def test_random_walk_speed_varies_over_time() -> None:
    world = World(WorldConfig(seed=1, duration_s=120))
    path = np.stack([world.car_positions(t) for t in np.arange(0.0, 120.0, 0.1)])
    speeds = np.linalg.norm(np.diff(path, axis=0), axis=2)[:, 0] / 0.1
    assert speeds.std() > 0.05


def test_polygon_cars_stop_at_random_for_seconds() -> None:
    world = World(WorldConfig(seed=2, motion="polygon", n_cars=4, duration_s=120))
    for track in world.tracks:
        still = np.all(np.diff(track.xy, axis=0) == 0, axis=1)
        stops = np.diff(track.times)[still]
        assert len(stops) >= 1 and np.all((stops >= 1.0) & (stops <= 4.0))


def test_cars_hold_their_position_after_the_duration() -> None:
    world = World(WorldConfig(seed=4, duration_s=10))
    np.testing.assert_array_equal(world.car_positions(50.0), world.car_positions(500.0))


def test_car_heading_follows_its_motion() -> None:
    world = World(WorldConfig(seed=9, duration_s=60))
    track = world.tracks[0]
    t = float(track.times[5] + track.times[6]) / 2
    (x0, y0), (x1, y1) = track.position(t - 0.01), track.position(t + 0.01)
    heading = track.heading(t)
    np.testing.assert_allclose([np.cos(heading), np.sin(heading)],
                               np.array([x1 - x0, y1 - y0]) / np.hypot(x1 - x0, y1 - y0),
                               atol=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"n_cars": 0}, "n_cars"),
        ({"n_cars": 51}, "n_cars"),
        ({"motion": "teleport"}, "motion"),
        ({"marker_size_m": 3.0}, "marker_size_m"),
        ({"min_speed_mps": 0.0}, "min_speed_mps"),
        ({"min_speed_mps": 2.0, "max_speed_mps": 1.0}, "min_speed_mps"),
        ({"duration_s": float("nan")}, "duration_s"),
        ({"n_cars": 50, "marker_size_m": 1.0}, "n_cars"),
    ],
)
def test_bad_world_config_names_the_field(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        WorldConfig(**kwargs)  # type: ignore[arg-type]


def test_bad_arena_is_rejected() -> None:
    with pytest.raises(ValueError, match="width_m"):
        Arena(width_m=-1.0)
