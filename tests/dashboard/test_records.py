"""What the dashboard takes from the network: good records pass as the browser gets them,
anything else raises ValueError naming the fault."""

from __future__ import annotations

import math
from typing import Any

import pytest

from wiswarm_zenoh.dashboard.records import (
    parse_deliveries,
    parse_leader,
    parse_points,
    parse_stats,
    parse_tracking,
)
from wiswarm_zenoh.transport.watch import loads

STATS = {"follower": "f1", "aoi_s": 0.01, "mean_aoi_s": 0.02, "p95_aoi_s": 0.05,
         "peak_aoi_s": 0.1, "p_hat": 0.9, "weight": 1.0, "polls": 10, "deliveries": 9,
         "timeouts": 1, "errors": 0, "stale": 0, "clock_offset_s": 0.0}


def test_a_batch_keeps_its_good_records_and_names_each_bad_one() -> None:
    good, bad = parse_deliveries([
        {"follower": "f1", "outcome": "delivered", "generated_at": 1.0, "delivered_at": 1.5},
        {"follower": "f2", "outcome": "timeout", "generated_at": None, "delivered_at": 2.0},
        {"follower": "f1", "outcome": "lost", "generated_at": 1.0, "delivered_at": 1.5},
        {"follower": "a/b", "outcome": "delivered", "generated_at": 1.0, "delivered_at": 1.5},
        {"follower": "f1", "outcome": "delivered", "generated_at": 3.0, "delivered_at": 1.5},
        {"follower": "f1", "outcome": "delivered", "generated_at": None, "delivered_at": 1.5},
        {"follower": "f1", "outcome": "timeout", "generated_at": 1.0, "delivered_at": 1.5},
        {"follower": "f1", "outcome": "delivered", "generated_at": 1.0,
         "delivered_at": math.inf},
        ["f1", "delivered", 1.0, 1.5],
    ])
    assert good == [("f1", 1.0, 1.5), ("f2", None, 2.0)]
    assert [reason.split()[0] for reason in bad] == [
        "outcome", "follower", "generated_at", "generated_at", "a", "delivered_at", "a"]


@pytest.mark.parametrize("data", [{"records": []}, "[]", None, 3])
def test_a_batch_is_a_list(data: Any) -> None:
    with pytest.raises(ValueError, match="must be a JSON list"):
        parse_deliveries(data)


def test_bytes_that_are_not_json_are_refused() -> None:
    assert loads(b'{"a": Infinity}') == {"a": math.inf}
    for payload in (b"\xff\xfe", b"{not json", b""):
        with pytest.raises(ValueError, match="not JSON"):
            loads(payload)


def test_stats_keep_the_contract_fields_and_no_infinity() -> None:
    record = parse_stats({**STATS, "aoi_s": math.inf, "extra": [1]}, "f1")
    assert record == {"follower": "f1", "aoi_s": None, "mean_aoi_s": 0.02, "p95_aoi_s": 0.05,
                      "p_hat": 0.9, "weight": 1.0, "polls": 10, "deliveries": 9,
                      "timeouts": 1, "errors": 0}


@pytest.mark.parametrize(("change", "words"), [
    ({"follower": "f2"}, "not the key's"),
    ({"p_hat": "high"}, "p_hat must be a number"),
    ({"polls": -1}, "polls must be a whole number"),
    ({"errors": 1.5}, "errors must be a whole number"),
    ({"weight": True}, "weight must be a number"),
])
def test_bad_stats_are_named(change: dict[str, Any], words: str) -> None:
    with pytest.raises(ValueError, match=words):
        parse_stats({**STATS, **change}, "f1")
    with pytest.raises(ValueError, match="JSON object"):
        parse_stats([STATS], "f1")


def test_leader_stats_name_the_leader_and_its_epoch() -> None:
    record = parse_leader({"followers": ["f1", "f2"], "polls_per_s": 900.0, "mean_aoi_s": 0.01,
                           "policy": "whittle", "uptime_s": 3.0, "leader": "edge-a",
                           "epoch": 17})
    assert record == {"followers": ["f1", "f2"], "polls_per_s": 900.0, "mean_aoi_s": 0.01,
                      "policy": "whittle", "uptime_s": 3.0, "leader": "edge-a", "epoch": 17}
    assert parse_leader({})["epoch"] == 0  # a push receiver's stats lack both
    for bad in ({"followers": "f1"}, {"leader": 3}, {"epoch": -2}):
        with pytest.raises(ValueError):
            parse_leader(bad)


def test_a_tracking_record_places_the_uav_its_car_footprint_and_plan() -> None:
    record = parse_tracking({
        "uav": "uav0", "frames": 10, "t": 5.0, "arena": [20.0, 10.0], "car": 0,
        "car_x": 3.0, "car_y": 4.0, "x": 3.1, "y": 4.2, "z": 2.0, "yaw": 0.5,
        "footprint": [[2.0, 3.0], [4.0, 3.0], [4.0, 5.0], [2.0, 5.0]],
        "waypoints": [[5.1, 3.2, 4.1, 2.0], [5.2, 3.3, 4.0, 2.0]],
        "error_m": 0.1, "in_view": True}, "uav0")
    assert record["arena"] == [20.0, 10.0]
    assert record["footprint"][2] == [4.0, 5.0]
    assert record["waypoints"][1] == [5.2, 3.3, 4.0, 2.0]
    assert (record["x"], record["car_y"], record["in_view"]) == (3.1, 4.0, True)
    assert "frames" not in record
    for bad in ({"uav": "uav1"}, {"footprint": [[1.0]]}, {"waypoints": [[1, 2, 3, math.nan]]},
                {"in_view": 1}, {"arena": 20}, {"car": "red"}):
        with pytest.raises(ValueError):
            parse_tracking(bad, "uav0")


def test_experiment_points_come_as_the_report_computes_them() -> None:
    point = {"label": "udp-opt", "n": 4, "rate": 10.0, "mean": {"mean_aoi_s": 0.2, "x": 1},
             "std": {"mean_aoi_s": 0.01}}
    record = parse_points({"study": "sweep", "run": "r", "baselines": ["udp", "tcp"],
                           "fixed_rate": 50, "done": False, "points": [point]}, "r")
    assert record == {"run": "r", "study": "sweep", "baselines": ["udp", "tcp"],
                      "fixed_rate": 50.0, "done": False, "points": [
                          {"label": "udp-opt", "n": 4, "rate": 10.0,
                           "mean": {"mean_aoi_s": 0.2}, "std": {"mean_aoi_s": 0.01}}]}
    for bad in ({"study": "", "fixed_rate": 50, "points": []},
                {"study": "s", "fixed_rate": "fifty", "points": []},
                {"study": "s", "fixed_rate": 50, "points": [{"label": "", "n": 2, "mean": {}}]},
                {"study": "s", "fixed_rate": 50, "points": [{"label": "w", "n": -2,
                                                             "mean": {}}]}):
        with pytest.raises(ValueError):
            parse_points(bad, "r")
