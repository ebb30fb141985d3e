"""Shared geometry: the arena, a UAV pose and a downward pinhole camera.

Conventions used everywhere in wiswarm_apps.tracking (so renderer and vision agree exactly):
world x points east in [0, width], y north in [0, height], z up (altitude); yaw is
counter-clockwise from +x. A frame pixel (u, v) has u to the right and v down, with
pixel centres at integer coordinates. The camera looks straight down; the top of the
image points along the UAV's heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

GrayImage = NDArray[np.uint8]
"""A grayscale image, shape (rows, cols)."""

Affine = NDArray[np.float64]
"""A 2x3 affine map (OpenCV layout): [x', y'] = A[:, :2] @ [x, y] + A[:, 2]."""


@dataclass(frozen=True)
class Arena:
    """The flight area: ground rectangle and the highest allowed altitude."""

    width_m: float = 20.0
    height_m: float = 10.0
    max_altitude_m: float = 10.0

    def __post_init__(self) -> None:
        for name in ("width_m", "height_m", "max_altitude_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        """True if (x, y) lies inside the ground rectangle shrunk by `margin`."""
        return (
            margin <= x <= self.width_m - margin and margin <= y <= self.height_m - margin
        )


@dataclass(frozen=True)
class Pose:
    """Where a UAV (and its camera) is: position in metres, yaw in radians."""

    x: float
    y: float
    z: float
    yaw: float = 0.0

    def as_tuple(self) -> tuple[float, float, float, float]:
        return (self.x, self.y, self.z, self.yaw)

    def is_finite(self) -> bool:
        return all(math.isfinite(value) for value in self.as_tuple())


@dataclass(frozen=True)
class CameraModel:
    """A downward pinhole camera: horizontal field of view and frame size in pixels."""

    fov_deg: float = 60.0
    width: int = 224
    height: int = 224

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fov_deg) and 0.0 < self.fov_deg < 170.0):
            raise ValueError(f"fov_deg must be in (0, 170), got {self.fov_deg!r}")
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 8 <= value <= 4096:
                raise ValueError(f"{name} must be an int in [8, 4096], got {value!r}")

    @property
    def frame_bytes(self) -> int:
        return self.width * self.height

    def metres_per_pixel(self, altitude_m: float) -> float:
        """Ground distance covered by one pixel when flying at `altitude_m`."""
        if not (math.isfinite(altitude_m) and altitude_m > 0):
            raise ValueError(f"altitude must be positive and finite, got {altitude_m!r}")
        return 2.0 * altitude_m * math.tan(math.radians(self.fov_deg) / 2.0) / self.width

    def frame_to_world(self, pose: Pose) -> Affine:
        """Affine map from frame pixel (u, v) to ground point (x, y) seen there."""
        s = self.metres_per_pixel(pose.z)
        fx, fy = math.cos(pose.yaw), math.sin(pose.yaw)  # heading: image up
        rx, ry = fy, -fx  # right of heading: image right
        cu, cv = (self.width - 1) / 2.0, (self.height - 1) / 2.0
        return np.array(
            [
                [s * rx, -s * fx, pose.x - s * cu * rx + s * cv * fx],
                [s * ry, -s * fy, pose.y - s * cu * ry + s * cv * fy],
            ],
            dtype=np.float64,
        )

    def pixel_to_world(self, pose: Pose, u: float, v: float) -> tuple[float, float]:
        m = self.frame_to_world(pose)
        return (
            float(m[0, 0] * u + m[0, 1] * v + m[0, 2]),
            float(m[1, 0] * u + m[1, 1] * v + m[1, 2]),
        )

    def world_to_pixel(self, pose: Pose, x: float, y: float) -> tuple[float, float]:
        m = invert_affine(self.frame_to_world(pose))
        return (
            float(m[0, 0] * x + m[0, 1] * y + m[0, 2]),
            float(m[1, 0] * x + m[1, 1] * y + m[1, 2]),
        )

    def sees(self, pose: Pose, x: float, y: float) -> bool:
        """True if ground point (x, y) projects inside the frame."""
        u, v = self.world_to_pixel(pose, x, y)
        return -0.5 <= u <= self.width - 0.5 and -0.5 <= v <= self.height - 0.5


def compose_affine(outer: Affine, inner: Affine) -> Affine:
    """The affine map `outer(inner(p))`."""
    out = np.empty((2, 3), dtype=np.float64)
    out[:, :2] = outer[:, :2] @ inner[:, :2]
    out[:, 2] = outer[:, :2] @ inner[:, 2] + outer[:, 2]
    return out


def invert_affine(m: Affine) -> Affine:
    out = np.empty((2, 3), dtype=np.float64)
    out[:, :2] = np.linalg.inv(m[:, :2])
    out[:, 2] = -out[:, :2] @ m[:, 2]
    return out


def wrap_angle(angle: float) -> float:
    """The same angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def world_to_ned(x: float, y: float, z: float) -> tuple[float, float, float]:
    """World (x east, y north, z up) to MAVLink local NED (north, east, down)."""
    return (y, x, -z)


def pose_from_ned(north: float, east: float, down: float, yaw_ned: float) -> Pose:
    """A world pose from MAVLink local NED position and yaw (clockwise from north)."""
    return Pose(east, north, -down, wrap_angle(math.pi / 2.0 - yaw_ned))


def yaw_to_ned(yaw: float) -> float:
    """World yaw (counter-clockwise from east) to MAVLink yaw (clockwise from north)."""
    return wrap_angle(math.pi / 2.0 - yaw)
