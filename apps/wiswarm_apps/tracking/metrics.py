"""Per-UAV tracking metrics, sampled at a steady rate so that plain sample means are
time averages: ground tracking error (metres and camera pixels), share of time the car
is in the field of view, and the age of the control information at the UAV.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from wiswarm_apps.tracking.geometry import CameraModel, Pose


@dataclass(frozen=True)
class Sample:
    """One look at a UAV and its car; `control_age_s` is None before any control."""

    t: float
    uav: Pose
    car_x: float
    car_y: float
    error_m: float
    error_px: float
    in_view: bool
    control_age_s: float | None


@dataclass(frozen=True)
class MetricsSummary:
    samples: int
    mean_tracking_error_m: float
    p95_tracking_error_m: float
    mean_tracking_error_px: float
    in_view_share: float
    mean_control_age_s: float
    p95_control_age_s: float
    control_updates: int


def _stat(values: list[float], q: float | None = None) -> float:
    if not values:
        return math.nan
    array = np.asarray(values, dtype=np.float64)
    return float(np.mean(array) if q is None else np.percentile(array, q))


class UavMetrics:
    """Accumulates one UAV's samples. Thread-safe: a sampler thread records while the
    control path reports receipts."""

    def __init__(self, name: str, camera: CameraModel) -> None:
        self.name = name
        self.camera = camera
        self._samples: list[Sample] = []
        self._control_generated_at: float | None = None
        self._control_updates = 0
        self._lock = threading.Lock()

    def control_received(self, generated_at: float) -> None:
        """The UAV adopted control information generated at `generated_at` (UAV clock);
        an older generation than the one held does not lower the age."""
        with self._lock:
            self._control_updates += 1
            held = self._control_generated_at
            if held is None or generated_at > held:
                self._control_generated_at = generated_at

    def record(self, t: float, uav: Pose, car_xy: tuple[float, float]) -> Sample:
        """Sample at time t: the UAV's pose against its car's true position."""
        car_x, car_y = car_xy
        error_m = math.hypot(uav.x - car_x, uav.y - car_y)
        error_px = error_m / self.camera.metres_per_pixel(uav.z) if uav.z > 0 else math.inf
        in_view = uav.z > 0 and self.camera.sees(uav, car_x, car_y)
        with self._lock:
            generated = self._control_generated_at
            age = None if generated is None else max(0.0, t - generated)
            sample = Sample(t, uav, car_x, car_y, error_m, error_px, in_view, age)
            self._samples.append(sample)
        return sample

    @property
    def samples(self) -> tuple[Sample, ...]:
        with self._lock:
            return tuple(self._samples)

    def summary(self) -> MetricsSummary:
        """Time averages (NaN where there is nothing to average yet)."""
        samples = self.samples
        errors = [s.error_m for s in samples]
        ages = [s.control_age_s for s in samples if s.control_age_s is not None]
        with self._lock:
            updates = self._control_updates
        return MetricsSummary(
            samples=len(samples),
            mean_tracking_error_m=_stat(errors),
            p95_tracking_error_m=_stat(errors, 95.0),
            mean_tracking_error_px=_stat([s.error_px for s in samples]),
            in_view_share=_stat([1.0 if s.in_view else 0.0 for s in samples]),
            mean_control_age_s=_stat(ages),
            p95_control_age_s=_stat(ages, 95.0),
            control_updates=updates,
        )
