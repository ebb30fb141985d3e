"""The ground world: cars carrying ArUco markers, moving deterministically from a seed.

Each car's whole trajectory is drawn up front as piecewise-linear knots, so a position
query is a cheap interpolation, any thread may ask, and the answer depends only on the
seed and t (never on the order of queries). After `duration_s` the cars stand still.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from wiswarm_apps.tracking.geometry import Arena

Motion = Literal["random_walk", "polygon"]
MOTIONS: tuple[Motion, ...] = ("random_walk", "polygon")
MAX_CARS = 50  # markers come from OpenCV's DICT_4X4_50
TAG_CELLS = 8  # a 4x4 ArUco marker is 6 cells with its black border, plus 1 white cell around


@dataclass(frozen=True)
class WorldConfig:
    """What the world looks like; every field is checked on construction."""

    arena: Arena = field(default_factory=Arena)
    n_cars: int = 4
    motion: Motion = "random_walk"
    marker_size_m: float = 0.3
    min_speed_mps: float = 0.1
    max_speed_mps: float = 0.6
    duration_s: float = 3600.0
    seed: int = 0
    separate: bool = True
    """Each car keeps to its own cell of a grid over the arena, so cars never overlap
    (real cars do not drive through each other, and overlapping tags hide each other)."""

    def __post_init__(self) -> None:
        if isinstance(self.n_cars, bool) or not 1 <= self.n_cars <= MAX_CARS:
            raise ValueError(f"n_cars must be in [1, {MAX_CARS}], got {self.n_cars!r}")
        if self.motion not in MOTIONS:
            raise ValueError(f"motion must be one of {MOTIONS}, got {self.motion!r}")
        arena_side = min(self.arena.width_m, self.arena.height_m)
        if not (self.marker_size_m > 0 and 4 * self.tag_size_m < arena_side):
            raise ValueError(f"marker_size_m {self.marker_size_m!r} does not fit the arena")
        if not 0 < self.min_speed_mps <= self.max_speed_mps <= 20:
            raise ValueError(
                "min_speed_mps/max_speed_mps must satisfy 0 < min <= max <= 20, got "
                f"{self.min_speed_mps!r}/{self.max_speed_mps!r}"
            )
        if not (math.isfinite(self.duration_s) and 0 < self.duration_s <= 86400):
            raise ValueError(f"duration_s must be in (0, 86400], got {self.duration_s!r}")
        lo, hi = self.car_boxes()[-1]
        if np.any(hi - lo < 0.5):
            raise ValueError(f"n_cars {self.n_cars} leaves each car less than 0.5 m to drive in")

    def car_boxes(self) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """Per car, the (low, high) corners of where its centre may go."""
        width, height = self.arena.width_m, self.arena.height_m
        rows = max(1, round(math.sqrt(self.n_cars * height / width))) if self.separate else 1
        cols = math.ceil(self.n_cars / rows) if self.separate else 1
        margin = self.tag_size_m * math.sqrt(0.5)  # a rotated tag stays inside its cell
        boxes = []
        for car in range(self.n_cars):
            col, row = (car % cols, car // cols) if self.separate else (0, 0)
            lo = np.array([col * width / cols + margin, row * height / rows + margin])
            hi = np.array([(col + 1) * width / cols - margin, (row + 1) * height / rows - margin])
            boxes.append((lo, hi))
        return boxes

    @property
    def tag_size_m(self) -> float:
        """Side of the whole tag on the car roof: marker plus white quiet border."""
        return self.marker_size_m * TAG_CELLS / (TAG_CELLS - 2)


@dataclass(frozen=True)
class CarTrack:
    """One car's trajectory: knot times, positions, and heading on leaving each knot."""

    times: NDArray[np.float64]
    xy: NDArray[np.float64]
    headings: NDArray[np.float64]

    def position(self, t: float) -> tuple[float, float]:
        return (
            float(np.interp(t, self.times, self.xy[:, 0])),
            float(np.interp(t, self.times, self.xy[:, 1])),
        )

    def heading(self, t: float) -> float:
        i = int(np.searchsorted(self.times, t, side="right")) - 1
        return float(self.headings[min(max(i, 0), len(self.headings) - 1)])


class _TrackBuilder:
    """Accumulates knots; headings follow the actual displacement (kept while stopped)."""

    def __init__(self, start: NDArray[np.float64], heading: float) -> None:
        self.t = 0.0
        self.pos = start
        self.heading = heading
        self._times = [0.0]
        self._xy = [start]
        self._headings: list[float] = []

    def go(self, end: NDArray[np.float64], duration: float) -> None:
        step = end - self.pos
        if float(np.hypot(step[0], step[1])) > 1e-9:
            self.heading = math.atan2(float(step[1]), float(step[0]))
        self._headings.append(self.heading)
        self.t += duration
        self.pos = end
        self._times.append(self.t)
        self._xy.append(end)

    def build(self) -> CarTrack:
        return CarTrack(
            times=np.asarray(self._times, dtype=np.float64),
            xy=np.asarray(self._xy, dtype=np.float64),
            headings=np.asarray([*self._headings, self.heading], dtype=np.float64),
        )


def _direction(heading: float) -> NDArray[np.float64]:
    return np.array([math.cos(heading), math.sin(heading)], dtype=np.float64)


def _random_walk(rng: np.random.Generator, cfg: WorldConfig, lo: NDArray[np.float64],
                 hi: NDArray[np.float64]) -> CarTrack:
    """Straight legs of 0.5-2 s with a fresh speed and a turn each; walls reflect."""
    builder = _TrackBuilder(rng.uniform(lo, hi), float(rng.uniform(-math.pi, math.pi)))
    heading = builder.heading
    while builder.t < cfg.duration_s:
        duration = float(rng.uniform(0.5, 2.0))
        distance = float(rng.uniform(cfg.min_speed_mps, cfg.max_speed_mps)) * duration
        heading += float(rng.normal(0.0, 0.5))
        end = builder.pos + distance * _direction(heading)
        if not lo[0] <= end[0] <= hi[0]:
            heading = math.pi - heading
        if not lo[1] <= end[1] <= hi[1]:
            heading = -heading
        end = np.clip(builder.pos + distance * _direction(heading), lo, hi)
        builder.go(end, duration)
    return builder.build()


def _polygon(rng: np.random.Generator, cfg: WorldConfig, lo: NDArray[np.float64],
             hi: NDArray[np.float64]) -> CarTrack:
    """A random star-shaped polygon driven round and round, stopping at random corners."""
    n_vertices = int(rng.integers(3, 7))
    centre = rng.uniform(lo + 0.4 * (hi - lo), hi - 0.4 * (hi - lo))
    reach = np.minimum(centre - lo, hi - centre)  # per axis: the polygon spans its box
    angles = np.sort(rng.uniform(0.0, 2.0 * math.pi, n_vertices))
    if rng.random() < 0.5:
        angles = angles[::-1]
    radii = rng.uniform(0.5, 1.0, n_vertices)
    vertices = np.clip(
        centre + radii[:, None] * reach * np.stack([np.cos(angles), np.sin(angles)], axis=1),
        lo, hi,
    )
    builder = _TrackBuilder(vertices[0], 0.0)
    k = 0
    while builder.t < cfg.duration_s:
        k = (k + 1) % n_vertices
        end = vertices[k]
        speed = float(rng.uniform(cfg.min_speed_mps, cfg.max_speed_mps))
        builder.go(end, float(np.hypot(*(end - builder.pos))) / speed + 1e-6)
        if rng.random() < 0.3:
            builder.go(end, float(rng.uniform(1.0, 4.0)))
    return builder.build()


class World:
    """Cars on the ground plane; car i carries ArUco marker id i (DICT_4X4_50)."""

    def __init__(self, config: WorldConfig | None = None) -> None:
        self.config = config if config is not None else WorldConfig()
        cfg = self.config
        make = _random_walk if cfg.motion == "random_walk" else _polygon
        seeds = np.random.SeedSequence(cfg.seed).spawn(cfg.n_cars)
        self.tracks: tuple[CarTrack, ...] = tuple(
            make(np.random.default_rng(seed), cfg, lo, hi)
            for seed, (lo, hi) in zip(seeds, cfg.car_boxes(), strict=True)
        )

    @property
    def arena(self) -> Arena:
        return self.config.arena

    @property
    def n_cars(self) -> int:
        return self.config.n_cars

    @property
    def marker_ids(self) -> tuple[int, ...]:
        return tuple(range(self.config.n_cars))

    def car_position(self, car: int, t: float) -> tuple[float, float]:
        return self.tracks[car].position(t)

    def car_positions(self, t: float) -> NDArray[np.float64]:
        """Positions of all cars at world time t, shape (n_cars, 2), metres."""
        return np.array([track.position(t) for track in self.tracks], dtype=np.float64)

    def car_headings(self, t: float) -> NDArray[np.float64]:
        """Headings (radians, counter-clockwise from +x) of all cars at world time t."""
        return np.array([track.heading(t) for track in self.tracks], dtype=np.float64)
