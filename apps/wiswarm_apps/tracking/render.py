"""Grayscale rendering of the world: what a UAV's downward camera sees.

Speed matters (up to 100 frames/s per UAV, several UAVs on two cores), so the textured
ground is rendered once and every frame is a single `cv2.warpAffine` crop of it; the
cars' tags are pre-rendered images warped into the frame only when they are in view.
OpenCV releases the GIL in these calls, so several UAV threads render in parallel.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from wiswarm_apps.tracking.geometry import (
    Affine,
    Arena,
    CameraModel,
    GrayImage,
    Pose,
    compose_affine,
    invert_affine,
)
from wiswarm_apps.tracking.world import TAG_CELLS, World

ARUCO_DICTIONARY = cv2.aruco.DICT_4X4_50
OUTSIDE_GRAY = 128  # what a camera sees beyond the arena's edge


def make_ground(arena: Arena, resolution_m: float, rng: np.random.Generator) -> GrayImage:
    """Mid-grey texture of smooth blobs at several scales: visible ground detail for the
    camera, but no dark straight-edged squares that could pass for a marker."""
    rows, cols = round(arena.height_m / resolution_m), round(arena.width_m / resolution_m)
    ground = np.full((rows, cols), 128.0, dtype=np.float32)
    for blob_m, amplitude in ((2.0, 22.0), (0.5, 16.0), (0.12, 9.0)):
        cells = rng.normal(0.0, 1.0, (
            max(2, math.ceil(arena.height_m / blob_m) + 1),
            max(2, math.ceil(arena.width_m / blob_m) + 1),
        )).astype(np.float32)
        ground += amplitude * cv2.resize(cells, (cols, rows), interpolation=cv2.INTER_CUBIC)
    fine = rng.normal(0.0, 4.0, (rows, cols)).astype(np.float32)
    ground += cv2.GaussianBlur(fine, (0, 0), 1.0)
    return np.clip(ground, 60.0, 200.0).astype(np.uint8)


def make_tag(marker_id: int, pixels_per_cell: int = 16) -> GrayImage:
    """An ArUco 4x4 marker with one white cell of quiet border around it."""
    dictionary = cv2.aruco.getPredefinedDictionary(ARUCO_DICTIONARY)
    marker = cv2.aruco.generateImageMarker(
        dictionary, marker_id, (TAG_CELLS - 2) * pixels_per_cell, borderBits=1
    )
    tag = cv2.copyMakeBorder(
        marker, pixels_per_cell, pixels_per_cell, pixels_per_cell, pixels_per_cell,
        cv2.BORDER_CONSTANT, value=(255,),
    )
    return np.asarray(tag, dtype=np.uint8)


def tag_to_world(size_px: int, side_m: float, x: float, y: float, heading: float) -> Affine:
    """Affine map from tag image pixels to the ground: the tag is centred on the car,
    its image x axis along the car's heading and its image up to the car's left."""
    k = side_m / size_px
    c, s = math.cos(heading), math.sin(heading)
    a0 = k / 2.0 - side_m / 2.0  # along-heading offset of tag pixel (0, 0)
    b0 = side_m / 2.0 - k / 2.0  # leftward offset of tag pixel (0, 0)
    return np.array(
        [[k * c, k * s, x + a0 * c - b0 * s], [k * s, -k * c, y + a0 * s + b0 * c]],
        dtype=np.float64,
    )


class Renderer:
    """Renders camera frames and overviews of one world. Safe to share between threads."""

    def __init__(self, world: World, ground_resolution_m: float = 0.01,
                 seed: int | None = None, pixels_per_cell: int = 16) -> None:
        if not (math.isfinite(ground_resolution_m) and 0.001 <= ground_resolution_m <= 0.5):
            raise ValueError(
                f"ground_resolution_m must be in [0.001, 0.5], got {ground_resolution_m!r}"
            )
        self.world = world
        self.resolution_m = ground_resolution_m
        arena = world.arena
        rng = np.random.default_rng(world.config.seed if seed is None else seed)
        self.ground = make_ground(arena, ground_resolution_m, rng)
        self.ground.setflags(write=False)
        r = ground_resolution_m
        self._world_to_ground = np.array(
            [[1.0 / r, 0.0, -0.5], [0.0, -1.0 / r, arena.height_m / r - 0.5]], dtype=np.float64
        )
        self._tags = tuple(make_tag(i, pixels_per_cell) for i in world.marker_ids)

    def frame(self, pose: Pose, camera: CameraModel, t: float) -> GrayImage:
        """The uint8 (height, width) image seen from `pose` at world time t."""
        frame_to_world = camera.frame_to_world(pose)
        crop = cv2.warpAffine(
            self.ground,
            compose_affine(self._world_to_ground, frame_to_world),
            (camera.width, camera.height),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(OUTSIDE_GRAY,),
        )
        image = np.asarray(crop, dtype=np.uint8)
        self._draw_cars(image, invert_affine(frame_to_world), t)
        return image

    def overview(self, t: float, resolution_m: float = 0.05) -> GrayImage:
        """The whole arena at world time t (north up), for plots and animations."""
        arena = self.world.arena
        size = (round(arena.width_m / resolution_m), round(arena.height_m / resolution_m))
        image = np.asarray(
            cv2.resize(self.ground, size, interpolation=cv2.INTER_AREA), dtype=np.uint8
        )
        r = resolution_m
        world_to_image = np.array(
            [[1.0 / r, 0.0, -0.5], [0.0, -1.0 / r, arena.height_m / r - 0.5]], dtype=np.float64
        )
        self._draw_cars(image, world_to_image, t)
        return image

    def _draw_cars(self, image: GrayImage, world_to_image: Affine, t: float) -> None:
        """Warp each visible car's tag into `image` in place (later cars on top)."""
        side_m = self.world.config.tag_size_m
        px_per_m = math.sqrt(abs(float(np.linalg.det(world_to_image[:, :2]))))
        reach = side_m * math.sqrt(0.5) * px_per_m + 2.0
        rows, cols = image.shape
        positions = self.world.car_positions(t)
        headings = self.world.car_headings(t)
        for tag, (x, y), heading in zip(self._tags, positions, headings, strict=True):
            u = world_to_image[0, 0] * x + world_to_image[0, 1] * y + world_to_image[0, 2]
            v = world_to_image[1, 0] * x + world_to_image[1, 1] * y + world_to_image[1, 2]
            if not (-reach <= u <= cols + reach and -reach <= v <= rows + reach):
                continue
            tag_to_image = compose_affine(
                world_to_image,
                tag_to_world(tag.shape[0], side_m, float(x), float(y), float(heading)),
            )
            cv2.warpAffine(
                tag, tag_to_image, (cols, rows), dst=image,
                flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_TRANSPARENT,
            )
