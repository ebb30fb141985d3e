"""Leader-side vision: find a car's ArUco marker in a frame and place it on the ground.

The marker centre is the mean of its four corners (exact for the affine view of a
downward camera); the frame's own pose and camera model turn it into world metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from wiswarm_apps.tracking.frames import Frame
from wiswarm_apps.tracking.geometry import GrayImage
from wiswarm_apps.tracking.render import ARUCO_DICTIONARY


@dataclass(frozen=True)
class Detection:
    """A marker found in a frame: centre in pixels and on the ground, apparent size."""

    marker_id: int
    u: float
    v: float
    x: float
    y: float
    side_px: float


class MarkerDetector:
    """Wraps one `cv2.aruco.ArucoDetector` (4x4 dictionary); use one per thread."""

    def __init__(self, subpixel: bool = False) -> None:
        params = cv2.aruco.DetectorParameters()
        # Sample each marker cell on 8x8 pixels (default 4x4): small markers seen at 45
        # degrees are otherwise misread (measured: 160x160 frames from 2.5 m). One 7-pixel
        # threshold window instead of three (3, 13, 23) finds as many markers from 0.8 to
        # 3.5 m and halves to quarters the detection time (measured on rendered frames).
        params.perspectiveRemovePixelPerCell = 8
        params.adaptiveThreshWinSizeMin = 7
        params.adaptiveThreshWinSizeMax = 7
        if subpixel:
            params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        dictionary = cv2.aruco.getPredefinedDictionary(ARUCO_DICTIONARY)
        self._detector = cv2.aruco.ArucoDetector(dictionary, params)

    def detect(self, pixels: GrayImage) -> dict[int, NDArray[np.float64]]:
        """All markers in the image: id -> corners, shape (4, 2), pixel coordinates."""
        corners, ids, _rejected = self._detector.detectMarkers(pixels)
        if ids is None:
            return {}
        found: dict[int, NDArray[np.float64]] = {}
        for quad, marker_id in zip(corners, np.asarray(ids).ravel(), strict=True):
            found.setdefault(int(marker_id), np.asarray(quad, dtype=np.float64).reshape(4, 2))
        return found

    def locate(self, frame: Frame, marker_id: int) -> Detection | None:
        """The given marker's ground position in this frame, or None if not seen."""
        quad = self.detect(frame.pixels).get(marker_id)
        if quad is None:
            return None
        u, v = (float(value) for value in quad.mean(axis=0))
        x, y = frame.camera.pixel_to_world(frame.pose, u, v)
        if not (math.isfinite(x) and math.isfinite(y)):
            return None
        side = float(np.mean(np.linalg.norm(quad - np.roll(quad, 1, axis=0), axis=1)))
        return Detection(marker_id=marker_id, u=u, v=v, x=x, y=y, side_px=side)
