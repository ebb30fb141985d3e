"""JSON schemas of the channels that carry our own records (Foxglove plots their fields
and reads their types from these)."""

from __future__ import annotations

from typing import Any

NUMBER, NULLABLE, COUNT, TEXT = ({"type": "number"}, {"type": ["number", "null"]},
                                 {"type": "integer"}, {"type": "string"})


def _object(title: str, properties: dict[str, Any]) -> dict[str, Any]:
    return {"type": "object", "title": title, "properties": properties}


DELIVERY = _object("wiswarm.Delivery", {
    "follower": TEXT, "outcome": {"type": "string", "enum": ["delivered", "timeout"]},
    "generated_at": NULLABLE, "delivered_at": NUMBER, "age_s": NULLABLE})
FOLLOWER_STATS = _object("wiswarm.FollowerStats", {
    "follower": TEXT, **dict.fromkeys(("aoi_s", "mean_aoi_s", "p95_aoi_s", "p_hat", "weight"),
                                      NULLABLE),
    **dict.fromkeys(("polls", "deliveries", "timeouts", "errors"), COUNT)})
LEADER_STATS = _object("wiswarm.LeaderStats", {
    "followers": {"type": "array", "items": TEXT}, "polls_per_s": NULLABLE,
    "mean_aoi_s": NULLABLE, "uptime_s": NULLABLE, "leader": TEXT, "policy": TEXT,
    "epoch": COUNT})
WAYPOINTS = {"type": "array", "items": {"type": "array", "items": NUMBER}}
CONTROL = _object("wiswarm.Control", {
    "seq": COUNT, "leader_time": NUMBER, "epoch": COUNT,
    "followers": {"type": "array", "items": _object("wiswarm.ControlEntry", {
        "follower": TEXT, "waypoints": WAYPOINTS})}})
TRACKING = _object("wiswarm.Tracking", {
    "uav": TEXT, "car": COUNT, "in_view": {"type": "boolean"},
    **dict.fromkeys(("t", "x", "y", "z", "yaw", "car_x", "car_y", "error_m", "mean_error_m",
                     "in_view_share", "control_age_s"), NULLABLE),
    "arena": {"type": "array", "items": NUMBER}, "waypoints": WAYPOINTS,
    "footprint": {"type": "array", "items": {"type": "array", "items": NUMBER}}})
