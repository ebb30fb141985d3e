"""Camera frame messages: raw grayscale pixels stamped with the pose at capture time.

A frame carries its own camera model (field of view and size), so the leader can turn
pixels into ground coordinates without per-UAV configuration. The decoder is strict:
anything malformed raises `FrameError` (one exception type for the caller to count).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import msgpack
import numpy as np

from wiswarm_apps.tracking.geometry import CameraModel, GrayImage, Pose
from wiswarm_zenoh.core import WireError

FRAME_VERSION = 1
_KEYS = frozenset({"v", "t", "pose", "fov", "w", "h", "px"})


class FrameError(WireError):
    """Bytes that are not a valid frame message (the message says what is wrong).
    A WireError, so shells that count malformed network data count these too."""


@dataclass(frozen=True)
class Frame:
    """One camera frame: capture time (UAV clock), pose at capture, camera, pixels."""

    t: float
    pose: Pose
    camera: CameraModel
    pixels: GrayImage


def encode_frame(frame: Frame) -> bytes:
    cam = frame.camera
    if frame.pixels.shape != (cam.height, cam.width) or frame.pixels.dtype != np.uint8:
        raise ValueError(
            f"pixels must be uint8 of shape {(cam.height, cam.width)}, "
            f"got {frame.pixels.dtype} {frame.pixels.shape}"
        )
    message = {
        "v": FRAME_VERSION,
        "t": float(frame.t),
        "pose": [float(value) for value in frame.pose.as_tuple()],
        "fov": float(cam.fov_deg),
        "w": cam.width,
        "h": cam.height,
        "px": np.ascontiguousarray(frame.pixels).tobytes(),
    }
    return bytes(msgpack.packb(message, use_bin_type=True))


def _finite(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FrameError(f"field {name} must be a number, got {type(value).__name__}")
    if not math.isfinite(value):
        raise FrameError(f"field {name} must be finite, got {value!r}")
    return float(value)


def decode_frame(data: bytes, expected: CameraModel | None = None) -> Frame:
    """Parse and check a frame message; `expected` also pins its camera model."""
    try:
        message = msgpack.unpackb(data, raw=False, strict_map_key=True)
    except Exception as exc:  # msgpack raises several unrelated types on garbage
        raise FrameError(f"undecodable msgpack: {exc}") from exc
    if not isinstance(message, dict) or set(message) != _KEYS:
        keys = sorted(message) if isinstance(message, dict) else type(message).__name__
        raise FrameError(f"frame must be a map with keys {sorted(_KEYS)}, got {keys}")
    if message["v"] != FRAME_VERSION:
        raise FrameError(f"unsupported frame version {message['v']!r}")
    raw_pose = message["pose"]
    if not isinstance(raw_pose, list) or len(raw_pose) != 4:
        raise FrameError("field pose must be a list [x, y, z, yaw]")
    pose = Pose(*(_finite(value, f"pose[{i}]") for i, value in enumerate(raw_pose)))
    if pose.z <= 0:
        raise FrameError(f"pose altitude must be positive, got {pose.z!r}")
    width, height = message["w"], message["h"]
    try:
        camera = CameraModel(_finite(message["fov"], "fov"), width, height)
    except ValueError as exc:
        raise FrameError(f"bad camera model: {exc}") from exc
    if expected is not None and camera != expected:
        raise FrameError(f"camera {camera} differs from the expected {expected}")
    pixels = message["px"]
    if not isinstance(pixels, bytes) or len(pixels) != camera.frame_bytes:
        size = len(pixels) if isinstance(pixels, bytes) else type(pixels).__name__
        raise FrameError(f"px must be {camera.frame_bytes} bytes for {width}x{height}, got {size}")
    image = np.frombuffer(pixels, dtype=np.uint8).reshape(height, width)
    return Frame(t=_finite(message["t"], "t"), pose=pose, camera=camera, pixels=image)
