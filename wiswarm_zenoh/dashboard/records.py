"""What the dashboard takes from the network, checked: anyone may publish on a swarm's
keys, so every JSON payload is judged before it is kept or shown.

Each ``parse_*`` returns the record the browser gets, or raises ``ValueError`` naming
the fault (the feed counts and logs it with the key expression). Numbers may be null (not
known yet); those that are not finite (``Infinity``: an age before any delivery) become
None too, since the browser's JSON cannot carry them. Extra fields are dropped; fields
a tool does not need may be missing, but a field that is there has the right type.
"""

from __future__ import annotations

import math
from typing import Any

from wiswarm_zenoh.core.messages import MAX_WAYPOINTS
from wiswarm_zenoh.transport.keys import check_follower, check_name

Record = dict[str, Any]

OUTCOMES = ("delivered", "timeout")
MAX_BATCH = 100_000  # records in one deliveries message (10 Hz of a leader at 1 MHz)
MAX_POINTS = 10_000  # points of one experiment run
STATS_NUMBERS = ("aoi_s", "mean_aoi_s", "p95_aoi_s", "p_hat", "weight")
STATS_COUNTS = ("polls", "deliveries", "timeouts", "errors")
LEADER_NUMBERS = ("polls_per_s", "mean_aoi_s", "uptime_s")
TRACKING_NUMBERS = ("t", "x", "y", "z", "yaw", "car_x", "car_y", "error_m", "mean_error_m",
                    "in_view_share", "control_age_s")
POINT_METRICS = ("mean_aoi_s", "p95_aoi_s", "peak_aoi_s", "throughput_fps", "throughput_mbps")
GENERATED_SLACK_S = 1e-3  # a generation time this far after its delivery is a rounding


def _object(data: Any, what: str) -> dict[str, Any]:
    if not isinstance(data, dict):
        raise ValueError(f"{what} must be a JSON object, got {type(data).__name__}")
    return data


def _number(value: Any, name: str) -> float | None:
    """A JSON number (None if it is null or not finite); ValueError for anything else."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{name} must be a number, got {value!r:.40}")
    number = float(value)
    return number if math.isfinite(number) else None


def _finite(value: Any, name: str) -> float:
    number = _number(value, name)
    if number is None:
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number


def _count(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f"{name} must be a whole number >= 0, got {value!r:.40}")
    return value


def _numbers(data: dict[str, Any], names: tuple[str, ...]) -> Record:
    return {name: _number(data[name], name) for name in names if name in data}


def parse_deliveries(data: Any) -> tuple[list[tuple[str, float | None, float]], list[str]]:
    """The leader's batch: ``(follower, generated_at or None, delivered_at)`` per good
    record, and the reason for each bad one (the good ones of a batch are kept)."""
    if not isinstance(data, list):
        raise ValueError(f"a deliveries batch must be a JSON list, got {type(data).__name__}")
    if len(data) > MAX_BATCH:
        raise ValueError(f"a deliveries batch of {len(data)} records (at most {MAX_BATCH})")
    good: list[tuple[str, float | None, float]] = []
    bad: list[str] = []
    for item in data:
        try:
            good.append(_delivery(item))
        except ValueError as exc:
            bad.append(str(exc))
    return good, bad


def _delivery(item: Any) -> tuple[str, float | None, float]:
    record = _object(item, "a delivery record")
    follower = record.get("follower")
    if not isinstance(follower, str):
        raise ValueError(f"follower must be a string, got {follower!r:.40}")
    check_follower(follower)
    outcome = record.get("outcome")
    if outcome not in OUTCOMES:
        raise ValueError(f"outcome must be one of {', '.join(OUTCOMES)}, got {outcome!r:.40}")
    delivered = _finite(record.get("delivered_at"), "delivered_at")
    if outcome == "timeout":
        if record.get("generated_at") is not None:
            raise ValueError("a timeout's generated_at must be null")
        return follower, None, delivered
    generated = _finite(record.get("generated_at"), "generated_at")
    if generated > delivered + GENERATED_SLACK_S:
        raise ValueError(f"generated_at {generated} is after delivered_at {delivered}")
    return follower, generated, delivered


def parse_stats(data: Any, follower: str) -> Record:
    """``wiswarm/<swarm>/<follower>/stats``: its ``follower`` must be the key's."""
    record = _object(data, "follower stats")
    if record.get("follower") != follower:
        raise ValueError(f"follower {record.get('follower')!r:.40} is not the key's {follower!r}")
    parsed = {"follower": follower, **_numbers(record, STATS_NUMBERS)}
    parsed.update({name: _count(record[name], name) for name in STATS_COUNTS if name in record})
    return parsed


def parse_leader(data: Any) -> Record:
    """``wiswarm/<swarm>/leader/stats``: who leads (``leader``, ``epoch``) and a summary."""
    record = _object(data, "leader stats")
    parsed = _numbers(record, LEADER_NUMBERS)
    followers = record.get("followers", [])
    if not isinstance(followers, list) or not all(isinstance(f, str) for f in followers):
        raise ValueError("followers must be a list of names")
    parsed["followers"] = followers
    for name in ("leader", "policy"):
        value = record.get(name, "")
        if not isinstance(value, str):
            raise ValueError(f"{name} must be a string, got {value!r:.40}")
        parsed[name] = value[:100]
    parsed["epoch"] = _count(record.get("epoch", 0), "epoch")
    return parsed


def _pairs(value: Any, name: str, width: int, most: int) -> list[list[float]]:
    """A list of at most ``most`` lists of ``width`` finite numbers."""
    if not isinstance(value, list) or len(value) > most:
        raise ValueError(f"{name} must be a list of at most {most} items")
    rows = []
    for item in value:
        if not isinstance(item, list) or len(item) != width:
            raise ValueError(f"each of {name} must be a list of {width} numbers")
        rows.append([_finite(v, name) for v in item])
    return rows


def parse_tracking(data: Any, uav: str) -> Record:
    """``wiswarm/<swarm>/<uav>/tracking`` (``wiswarm_apps.tracking.uav_app``): where the UAV, its
    car, its camera's footprint and its waypoints are, for the map; and the live row."""
    record = _object(data, "a tracking record")
    if record.get("uav", uav) != uav:
        raise ValueError(f"uav {record.get('uav')!r:.40} is not the key's {uav!r}")
    parsed: Record = {"uav": uav, **_numbers(record, TRACKING_NUMBERS)}
    if "car" in record:
        parsed["car"] = _count(record["car"], "car")
    if "in_view" in record:
        if not isinstance(record["in_view"], bool):
            raise ValueError("in_view must be true or false")
        parsed["in_view"] = record["in_view"]
    if "arena" in record:
        parsed["arena"] = _pairs([record["arena"]], "arena", 2, 1)[0]
    if "footprint" in record:
        parsed["footprint"] = _pairs(record["footprint"], "footprint", 2, 8)
    if "waypoints" in record:
        parsed["waypoints"] = _pairs(record["waypoints"], "waypoints", 4, MAX_WAYPOINTS)
    return parsed


def parse_points(data: Any, run: str) -> Record:
    """``wiswarm/experiments/<run>/points`` (``live_points``): every point so far."""
    record = _object(data, "experiment points")
    check_name(run, "run name")
    study = record.get("study")
    if not isinstance(study, str) or not study:
        raise ValueError("study must be a non-empty string")
    baselines = record.get("baselines", [])
    if not isinstance(baselines, list) or not all(isinstance(b, str) for b in baselines):
        raise ValueError("baselines must be a list of names")
    points = record.get("points")
    if not isinstance(points, list) or len(points) > MAX_POINTS:
        raise ValueError(f"points must be a list of at most {MAX_POINTS}")
    return {"run": run, "study": study[:40], "baselines": baselines,
            "fixed_rate": _finite(record.get("fixed_rate"), "fixed_rate"),
            "done": bool(record.get("done", False)),
            "points": [_point(p) for p in points]}


def _point(item: Any) -> Record:
    point = _object(item, "a point")
    label, n = point.get("label"), _count(point.get("n"), "n")
    if not isinstance(label, str) or not label:
        raise ValueError("a point's label must be a non-empty string")
    rate = point.get("rate")
    mean = _object(point.get("mean"), "a point's mean")
    std = _object(point.get("std", {}), "a point's std")
    return {"label": label[:40], "n": n, "rate": None if rate is None else _finite(rate, "rate"),
            "mean": _numbers(mean, POINT_METRICS), "std": _numbers(std, POINT_METRICS)}
