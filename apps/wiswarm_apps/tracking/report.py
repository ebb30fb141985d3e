"""The demo's numbers and files: `summary.json`, CSVs, and the console summary.

`summary.json` has, per UAV and averaged over the UAVs, `mean_aoi_s`, `p95_aoi_s`
(time statistics of the AoI sawtooth at the leader over the window),
`mean_tracking_error_m` and `in_view_share` (time averages of the UAV's own samples),
and more; and `systems`: per system run, its averages (`mean_aoi_s`, `p95_aoi_s`,
`tracking_error_m`, `in_view`), camera rate, channel and UAVs. A comparison of systems
(``compare``) keeps just that, for every system, and their ratios. A value that could
not be measured (a UAV that handed nothing back) is null.
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

from wiswarm_apps.tracking.demo import DemoOptions, DemoRun
from wiswarm_apps.tracking.reception import DeliveryRow
from wiswarm_apps.tracking.uav_app import SAMPLE_FIELDS
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


def channel_entry(options: DemoOptions) -> dict[str, object] | None:
    """The channel a run crossed (None: loopback, nothing scarce): a shared link's shape,
    or the WiFi medium's."""
    spec = options.channel
    if spec is None:
        return None
    if isinstance(spec, ChannelSpec):
        return {"kind": options.channel_kind, "rate_bps": spec.rate_bps,
                "down_rate_bps": spec.down_bps, "queue_s": spec.queue_s,
                "burst_bytes": spec.burst_bytes}
    return {"kind": options.channel_kind, **asdict(spec)}


def system_entry(rate_hz: float, channel: dict[str, object] | None, mean: dict[str, Number],
                 per_uav: dict[str, dict[str, Number]]) -> dict[str, object]:
    """One system's line of ``systems`` in summary.json: its averages over the UAVs, the
    channel it ran over, its camera rate, and its UAVs."""
    return {"mean_aoi_s": mean["mean_aoi_s"], "p95_aoi_s": mean["p95_aoi_s"],
            "tracking_error_m": mean["mean_tracking_error_m"], "in_view": mean["in_view_share"],
            "rate_hz": rate_hz, "channel": channel, "per_uav": per_uav}


def summarise(run: DemoRun) -> dict[str, object]:
    options = run.options
    per_uav = {uav: uav_summary(run, uav) for uav in options.uav_ids}
    mean = average(per_uav.values())
    channel = channel_entry(options)
    span = max(run.measured_s, 1e-9)
    deliveries = sum(a.deliveries for a in run.aoi.values())
    processed = sum(v.processed for v in run.vision.values())
    return {
        "system": options.system, "uavs": options.uavs, "duration_s": options.duration_s,
        "measured_s": run.measured_s, "seed": options.seed, "rate_hz": options.rate,
        "frame_px": options.frame_px, "vehicle": options.vehicle, "motion": options.motion,
        "policy": options.policy if options.system == "wiswarm" else None,
        "channel": channel,
        "per_uav": per_uav,
        "average": mean,
        "systems": {options.system: system_entry(options.rate, channel, mean, per_uav)},
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


def write_summary(out: Path, summary: dict[str, object]) -> Path:
    """``out/summary.json`` (the directory is made if missing)."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / "summary.json"
    path.write_text(json.dumps(summary, indent=2, allow_nan=False) + "\n")
    return path


def write_outputs(out: Path, run: DemoRun, summary: dict[str, object]) -> list[Path]:
    """summary.json, per_uav.csv, tracking.csv (UAV samples), deliveries.csv."""
    paths = [write_summary(out, summary)] + [
        out / name for name in ("per_uav.csv", "tracking.csv", "deliveries.csv")]
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


COMPARED = (("mean_aoi_s", "AoI mean (ms)", 1e3, 1), ("p95_aoi_s", "AoI p95 (ms)", 1e3, 1),
            ("tracking_error_m", "tracking error (m)", 1.0, 3),
            ("in_view", "car in view (%)", 100.0, 1))


def compare(summaries: dict[str, dict[str, object]]) -> dict[str, object]:
    """The summary.json of runs of several systems in the same world: what they share,
    ``systems`` (each run's entry) and, for each later system, its ratios to the first
    (``push_over_wiswarm``: how many times staler and worse it tracks)."""
    first = next(iter(summaries.values()))
    out: dict[str, object] = {key: first[key] for key in (
        "uavs", "duration_s", "seed", "frame_px", "vehicle", "motion", "channel")}
    entries: dict[str, dict[str, object]] = {}
    for system, summary in summaries.items():
        systems = summary["systems"]
        assert isinstance(systems, dict)
        entries[system] = {**systems[system], "measured_s": summary["measured_s"]}
    out["systems"] = entries
    base_name, base = next(iter(entries.items()))
    for name, entry in list(entries.items())[1:]:
        out[f"{name}_over_{base_name}"] = {
            key.removesuffix("_s").removesuffix("_m"): _ratio(entry[key], base[key])
            for key in ("mean_aoi_s", "p95_aoi_s", "tracking_error_m")}
    return out


def _ratio(value: object, base: object) -> Number:
    if not isinstance(value, float) or not isinstance(base, float) or base <= 0:
        return None
    return value / base


def comparison_lines(comparison: dict[str, object]) -> list[str]:
    """The side-by-side summary: a column per system, and the ratio to the first."""
    entries = comparison["systems"]
    assert isinstance(entries, dict)
    names = list(entries)
    labels = [f"{name}@{entries[name]['rate_hz']:g}fps" for name in names]
    ratio_head = f"{names[-1]} / {names[0]}" if len(names) > 1 else ""
    lines = [f"{'':20}" + "".join(f"{label:>16}" for label in labels) + f"{ratio_head:>18}"]
    for key, label, scale, digits in COMPARED:
        values = [entries[name][key] for name in names]
        cells = "".join(f"{'-' if v is None else f'{v * scale:.{digits}f}':>16}" for v in values)
        ratio = _ratio(values[-1], values[0]) if len(names) > 1 and key != "in_view" else None
        lines.append(f"{label:20}{cells}" + (f"{ratio:>17.1f}x" if ratio is not None else ""))
    return lines
