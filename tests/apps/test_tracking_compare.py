"""The comparison of systems in summary.json and on the console: each system's entry,
the ratios to the first, and a value that could not be measured."""

from __future__ import annotations

import pytest

from wiswarm_apps.tracking.report import compare, comparison_lines, system_entry

CHANNEL = {"kind": "user", "rate_bps": 20_000_000}


def summary(system: str, rate: float, aoi: float | None, error: float) -> dict[str, object]:
    """What ``summarise`` gives, as far as ``compare`` reads it."""
    mean = {"mean_aoi_s": aoi, "p95_aoi_s": None if aoi is None else 2 * aoi,
            "mean_tracking_error_m": error, "in_view_share": 0.5}
    per_uav = {"uav0": dict(mean)}
    return {"uavs": 1, "duration_s": 30.0, "seed": 0, "frame_px": 224, "vehicle": "virtual",
            "motion": "random_walk", "channel": CHANNEL, "measured_s": 30.0,
            "systems": {system: system_entry(rate, CHANNEL, mean, per_uav)}}


def test_each_system_keeps_its_entry_and_later_ones_get_ratios_to_the_first() -> None:
    out = compare({"wiswarm": summary("wiswarm", 100, 0.05, 0.01),
                   "push": summary("push", 50, 5.0, 2.0)})
    assert out["channel"] == CHANNEL and out["uavs"] == 1
    systems = out["systems"]
    assert isinstance(systems, dict) and list(systems) == ["wiswarm", "push"]
    assert systems["push"]["tracking_error_m"] == 2.0 and systems["push"]["rate_hz"] == 50
    assert systems["wiswarm"]["per_uav"]["uav0"]["mean_aoi_s"] == 0.05
    assert out["push_over_wiswarm"] == pytest.approx(
        {"mean_aoi": 100.0, "p95_aoi": 100.0, "tracking_error": 200.0})


def test_a_value_not_measured_has_no_ratio_and_prints_a_dash() -> None:
    out = compare({"wiswarm": summary("wiswarm", 100, None, 0.01),
                   "push": summary("push", 50, 5.0, 2.0)})
    ratios = out["push_over_wiswarm"]
    assert isinstance(ratios, dict) and ratios["mean_aoi"] is None
    lines = comparison_lines(out)
    assert lines[0].split() == ["wiswarm@100fps", "push@50fps", "push", "/", "wiswarm"]
    assert lines[1].split() == ["AoI", "mean", "(ms)", "-", "5000.0"]  # no ratio
    assert lines[3].split() == ["tracking", "error", "(m)", "0.010", "2.000", "200.0x"]
    assert lines[4].split() == ["car", "in", "view", "(%)", "50.0", "50.0"]


def test_one_system_alone_is_a_column_without_ratios() -> None:
    out = compare({"wiswarm": summary("wiswarm", 100, 0.05, 0.01)})
    assert not any(key.endswith("_over_wiswarm") for key in out)
    assert comparison_lines(out)[1].split() == ["AoI", "mean", "(ms)", "50.0"]
