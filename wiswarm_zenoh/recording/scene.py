"""The arena for Foxglove's 3D panel (``foxglove.SceneUpdate``), from one UAV's tracking
record (``wiswarm/<swarm>/<uav>/tracking``, checked by the dashboard's ``records``):
the UAV, its car, its camera's footprint and its waypoints, in the frame ``world``."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from foxglove.messages import (
    Color,
    CubePrimitive,
    LinePrimitive,
    LinePrimitiveLineType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    SpherePrimitive,
    Timestamp,
    Vector3,
)

WORLD = "world"
UAV_SIZE_M = 0.3
CAR_SIZE_M = 0.2
UAV_COLOUR = Color(r=0.2, g=0.5, b=1.0, a=1.0)
CAR_COLOUR = Color(r=1.0, g=0.4, b=0.1, a=1.0)
FOOTPRINT_COLOUR = Color(r=0.2, g=0.5, b=1.0, a=0.6)
PLAN_COLOUR = Color(r=0.1, g=0.8, b=0.3, a=1.0)


def _pose(x: float, y: float, z: float, yaw: float = 0.0) -> Pose:
    return Pose(position=Vector3(x=x, y=y, z=z),
                orientation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)))


def _line(kind: LinePrimitiveLineType, points: Sequence[Sequence[float]],
          colour: Color) -> LinePrimitive:
    return LinePrimitive(type=kind, pose=_pose(0.0, 0.0, 0.0), thickness=0.03,
                         points=[Point3(x=p[0], y=p[1], z=p[2] if len(p) > 2 else 0.0)
                                 for p in points], color=colour)


def arena_update(record: dict[str, Any], at: float) -> SceneUpdate:
    """The entities of ``record``'s UAV (``<uav>``) and car (``<uav>/car``) as they are
    at ``at`` (seconds since the epoch); what the record lacks is left out."""
    uav, stamp = record["uav"], Timestamp.from_epoch_secs(at)
    entities = []
    if record.get("car_x") is not None and record.get("car_y") is not None:
        entities.append(SceneEntity(timestamp=stamp, frame_id=WORLD, id=f"{uav}/car",
                                    spheres=[SpherePrimitive(
                                        pose=_pose(record["car_x"], record["car_y"], 0.0),
                                        size=Vector3(x=CAR_SIZE_M, y=CAR_SIZE_M, z=CAR_SIZE_M),
                                        color=CAR_COLOUR)]))
    cubes, lines = [], []
    if all(record.get(name) is not None for name in ("x", "y", "z")):
        cubes.append(CubePrimitive(pose=_pose(record["x"], record["y"], record["z"],
                                              record.get("yaw") or 0.0),
                                   size=Vector3(x=UAV_SIZE_M, y=UAV_SIZE_M, z=UAV_SIZE_M / 3),
                                   color=UAV_COLOUR))
    if record.get("footprint"):
        lines.append(_line(LinePrimitiveLineType.LineLoop, record["footprint"],
                           FOOTPRINT_COLOUR))
    if record.get("waypoints"):
        lines.append(_line(LinePrimitiveLineType.LineStrip,
                           [waypoint[1:] for waypoint in record["waypoints"]], PLAN_COLOUR))
    if cubes or lines:
        entities.append(SceneEntity(timestamp=stamp, frame_id=WORLD, id=uav, cubes=cubes,
                                    lines=lines))
    return SceneUpdate(entities=entities)
