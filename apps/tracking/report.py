"""The demo's numbers and files: `summary.json`, CSVs, and the console summary.

`summary.json` has, per UAV and averaged over the UAVs, `mean_aoi_s`, `p95_aoi_s`
(time statistics of the AoI sawtooth at the leader over the window),
`mean_tracking_error_m` and `in_view_share` (time averages of the UAV's own samples),
and more. A value that could not be measured (a UAV that handed nothing back) is null.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from apps.tracking.demo import DemoOptions, DemoRun
from apps.tracking.reception import DeliveryRow
from apps.tracking.uav_app import SAMPLE_FIELDS
from wiswarm_zenoh.testbed import ChannelSpec

MAIN_KEYS = ("mean_aoi_s", "p95_aoi_s", "mean_tracking_error_m", "in_view_share")
UAV_KEYS = (*MAIN_KEYS, "peak_aoi_s", "p95_tracking_error_m", "mean_tracking_error_px",
            "mean_control_age_s", "deliveries_per_s", "processed_per_s", "superseded",
            "bad_frames", "frames_per_s", "waypoints_rejected")
Number = float | None


def _clean(value: float | int | None) -> Number:
    if value is None or not math.isfinite(value):
        return None
    return float(value)


def uav_summary(run: DemoRun, uav: str) -> dict[str, Number]:
    span = max(run.measured_s, 1e-9)
    aoi, vision, result = run.aoi.get(uav), run.vision.get(uav), run.uavs.get(uav)
    values: dict[str, float | int | None] = dict.fromkeys(UAV_KEYS)
    if aoi is not None:
        values.update(mean_aoi_s=aoi.mean_aoi_s, p95_aoi_s=aoi.p95_aoi_s,
                      peak_aoi_s=aoi.peak_aoi_s, deliveries_per_s=aoi.deliveries / span)
    if vision is not None:
        values.update(processed_per_s=vision.processed / span, superseded=vision.superseded,
                      bad_frames=vision.bad_frames)
    if result is not None:
        values.update({key: result.summary[key] for key in (
            "mean_tracking_error_m", "p95_tracking_error_m", "mean_tracking_error_px",
            "in_view_share", "mean_control_age_s")})
        values.update(waypoints_rejected=result.counters["waypoints_rejected"],
                      frames_per_s=result.counters["frames_in_window"] / span)
    return {key: _clean(value) for key, value in values.items()}


def average(per_uav: Iterable[dict[str, Number]]) -> dict[str, Number]:
    """The mean over the UAVs that have a value for each key."""
    rows = list(per_uav)
    out: dict[str, Number] = {}
    for key in UAV_KEYS:
        values = [row[key] for row in rows if row.get(key) is not None]
        out[key] = float(np.mean(np.asarray(values, dtype=np.float64))) if values else None
    return out


def _channel(options: DemoOptions) -> dict[str, object] | None:
    """What the UAVs were behind: the tbf channel's shape, or the WiFi medium's."""
    channel = options.channel
    if channel is None:
        return None
    if isinstance(channel, ChannelSpec):
        return {"rate_bps": channel.rate_bps, "down_rate_bps": channel.down_bps,
                "queue_s": channel.queue_s, "burst_bytes": channel.burst_bytes}
    return {"medium": "wifi", **asdict(channel)}


def summarise(run: DemoRun) -> dict[str, object]:
    options = run.options
    per_uav = {uav: uav_summary(run, uav) for uav in options.uav_ids}
    span = max(run.measured_s, 1e-9)
    deliveries = sum(a.deliveries for a in run.aoi.values())
    processed = sum(v.processed for v in run.vision.values())
    return {
        "system": options.system, "uavs": options.uavs, "duration_s": options.duration_s,
        "measured_s": run.measured_s, "seed": options.seed, "rate_hz": options.rate,
        "frame_px": options.frame_px, "vehicle": options.vehicle, "motion": options.motion,
        "policy": options.policy if options.system == "wiswarm" else None,
        "channel": _channel(options),
        "per_uav": per_uav,
        "average": average(per_uav.values()),
        "leader": {
            "deliveries_per_s": deliveries / span, "processed_per_s": processed / span,
            "vision_busy_share": _clean(run.vision_busy_s / (span + options.warmup_s)),
            "polls_per_s": run.polls / (span + options.warmup_s),
            "uavs_reporting": len(run.uavs),
        },
    }


def aoi_series(rows: Sequence[DeliveryRow], uav: str, start: float, end: float,
               step: float = 0.001) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The AoI sawtooth of one UAV sampled every `step` over [start, end] (leader clock):
    age = t - the newest generation time delivered by t (the window's start before any)."""
    mine = sorted((r for r in rows if r.uav == uav), key=lambda r: r.received_at)
    t = np.arange(start, end, step, dtype=np.float64)
    received = np.asarray([r.received_at for r in mine], dtype=np.float64)
    newest = np.maximum.accumulate(
        np.asarray([start] + [r.generated_at for r in mine], dtype=np.float64)
    )
    index = np.searchsorted(received, t, side="right")
    return t, t - newest[index]


def write_outputs(out: Path, run: DemoRun, summary: dict[str, object]) -> list[Path]:
    """summary.json, per_uav.csv, tracking.csv (UAV samples), deliveries.csv."""
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / name for name in ("summary.json", "per_uav.csv", "tracking.csv",
                                     "deliveries.csv")]
    paths[0].write_text(json.dumps(summary, indent=2, allow_nan=False) + "\n")
    per_uav = summary["per_uav"]
    assert isinstance(per_uav, dict)
    _write_csv(paths[1], ("uav", *UAV_KEYS),
               ([uav, *(per_uav[uav][k] for k in UAV_KEYS)] for uav in sorted(per_uav)))
    _write_csv(paths[2], ("uav", *SAMPLE_FIELDS),
               ([uav, *sample] for uav, result in sorted(run.uavs.items())
                for sample in result.samples))
    _write_csv(paths[3], ("uav", "generated_at_s", "received_at_s", "age_s"),
               ([r.uav, r.generated_at - run.epoch, r.received_at - run.epoch,
                 r.received_at - r.generated_at] for r in run.deliveries))
    return paths


def _write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[object]]) -> None:
    with path.open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(header)
        for row in rows:
            writer.writerow(["" if v is None else f"{v:.6g}" if isinstance(v, float) else v
                             for v in row])


def summary_lines(summary: dict[str, object]) -> list[str]:
    """The console summary: one line per UAV and the average."""
    per_uav, avg = summary["per_uav"], summary["average"]
    assert isinstance(per_uav, dict) and isinstance(avg, dict)

    def fmt(row: dict[str, Number]) -> str:
        def get(key: str, scale: float, digits: int) -> str:
            value = row.get(key)
            return "-" if value is None else f"{value * scale:.{digits}f}"
        return (f"AoI mean {get('mean_aoi_s', 1e3, 1)} ms, p95 {get('p95_aoi_s', 1e3, 1)} ms;"
                f" tracking error {get('mean_tracking_error_m', 1, 3)} m;"
                f" car in view {get('in_view_share', 100, 1)}%")

    lines = [f"{summary['system']}: {summary['uavs']} UAVs, {summary['measured_s']:.1f} s "
             f"measured, {summary['rate_hz']:g} frames/s per UAV"]
    lines += [f"  {uav:>6}: {fmt(per_uav[uav])}" for uav in sorted(per_uav)]
    lines.append(f"  {'mean':>6}: {fmt(avg)}")
    leader = summary["leader"]
    assert isinstance(leader, dict)
    lines.append(f"  leader: {leader['deliveries_per_s']:.0f} deliveries/s, "
                 f"vision {leader['processed_per_s']:.0f} frames/s")
    return lines
