"""Leader-side planning for one UAV: from car sightings to future waypoints.

The paper's scheme: keep the car's recent positions, estimate its velocity, extrapolate
linearly to time-stamped waypoints above the car, and report the car-UAV relative speed
as the urgency signal v (the middleware turns it into a weight with an EMA). A line
fitted over a short window, rather than the last two sightings, keeps one noisy corner
from throwing the plan. When the car is not in a frame the last plan stands.
All times are in the UAV's clock (frames are stamped with it).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wiswarm_apps.tracking.frames import Frame
from wiswarm_apps.tracking.geometry import Arena
from wiswarm_apps.tracking.vision import Detection
from wiswarm_zenoh.core import Waypoint


@dataclass(frozen=True)
class TrackerConfig:
    """Planning parameters; checked on construction."""

    altitude_m: float = 2.0
    horizon_s: float = 1.0
    step_s: float = 0.1
    window_s: float = 0.5
    history: int = 30
    min_urgency: float = 0.05

    def __post_init__(self) -> None:
        for name in ("altitude_m", "horizon_s", "step_s", "window_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if self.step_s > self.horizon_s:
            raise ValueError(f"step_s {self.step_s} exceeds horizon_s {self.horizon_s}")
        if isinstance(self.history, bool) or not 2 <= self.history <= 10_000:
            raise ValueError(f"history must be in [2, 10000], got {self.history!r}")
        if not (math.isfinite(self.min_urgency) and self.min_urgency >= 0):
            raise ValueError(f"min_urgency must be >= 0, got {self.min_urgency!r}")


@dataclass(frozen=True)
class Plan:
    """What the leader knows and wants for one UAV after its latest frame."""

    waypoints: tuple[Waypoint, ...]
    urgency: float
    car_seen: bool
    missed_frames: int
    last_seen_t: float | None
    car_xy: tuple[float, float] | None
    car_velocity: tuple[float, float]


def fit_motion(
    samples: deque[tuple[float, float, float]], window_s: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Least-squares line through the samples (t, x, y) of the last `window_s` seconds:
    (position at the latest sample time, velocity). One sample gives zero velocity."""
    data = np.asarray(samples, dtype=np.float64)
    data = data[data[:, 0] >= data[-1, 0] - window_s]
    dt = data[:, 0] - data[-1, 0]
    spread = float(np.sum((dt - dt.mean()) ** 2))
    if len(data) < 2 or spread < 1e-9:
        return data[-1, 1:].copy(), np.zeros(2)
    centred = data[:, 1:] - data[:, 1:].mean(axis=0)
    velocity = ((dt - dt.mean()) @ centred) / spread
    position = data[:, 1:].mean(axis=0) - velocity * dt.mean()
    return position, velocity


class CarTracker:
    """Tracks one car for one UAV. Not thread-safe: the leader's vision thread owns it."""

    def __init__(self, arena: Arena, config: TrackerConfig | None = None) -> None:
        self.arena = arena
        self.config = config if config is not None else TrackerConfig()
        self._cars: deque[tuple[float, float, float]] = deque(maxlen=self.config.history)
        self._uav: deque[tuple[float, float, float]] = deque(maxlen=self.config.history)
        self._plan = Plan((), 0.0, False, 0, None, None, (0.0, 0.0))

    @property
    def plan(self) -> Plan:
        return self._plan

    def update(self, frame: Frame, detection: Detection | None, now: float) -> Plan:
        """Fold in one processed frame and return the plan; waypoints start at `now`.
        Frames not newer than the last one change nothing."""
        if self._uav and frame.t <= self._uav[-1][0]:
            return self._plan
        self._uav.append((frame.t, frame.pose.x, frame.pose.y))
        last = self._plan
        if detection is None:
            self._plan = Plan(last.waypoints, last.urgency, False, last.missed_frames + 1,
                              last.last_seen_t, last.car_xy, last.car_velocity)
            return self._plan
        self._cars.append((frame.t, detection.x, detection.y))
        cfg = self.config
        car_at, car_v = fit_motion(self._cars, cfg.window_s)
        _, uav_v = fit_motion(self._uav, cfg.window_s)
        steps = max(1, round(cfg.horizon_s / cfg.step_s))
        waypoints: list[Waypoint] = []
        for k in range(steps + 1):
            t = now + k * cfg.step_s
            x, y = car_at + car_v * (t - frame.t)
            waypoints.append((
                t,
                min(max(float(x), 0.0), self.arena.width_m),
                min(max(float(y), 0.0), self.arena.height_m),
                min(cfg.altitude_m, self.arena.max_altitude_m),
            ))
        relative = float(np.hypot(*(car_v - uav_v)))
        self._plan = Plan(
            waypoints=tuple(waypoints),
            urgency=max(cfg.min_urgency, relative),
            car_seen=True,
            missed_frames=0,
            last_seen_t=frame.t,
            car_xy=(float(car_at[0]), float(car_at[1])),
            car_velocity=(float(car_v[0]), float(car_v[1])),
        )
        return self._plan
