"""Mobility tracking over Zenoh on loopback: WiSwarm (polled LIFO, 100 frames/s) against
the push baseline (FIFO, frames put at a fixed rate), as `wiswarm demo` runs them.

For each system: an embedded router, N UAV processes (spawn) sending 224x224 frames,
and the leader (vision, trackers, LeaderNode or push subscriber) in this process. It
prints, averaged over the UAVs, the mean and p95 AoI at the leader (target: mean
<= 50 ms), the mean tracking error (target <= 0.4 m) and the share of time the car is
in view; and for the leader's vision thread, frames processed per second against
deliveries per second (target: keeps up), its busy share, and the frames a newer one
replaced before it was processed.

    .venv/bin/python benchmarks/bench_tracking.py                  # 4 UAVs, 30 s each
    .venv/bin/python benchmarks/bench_tracking.py --seconds 10 --systems wiswarm
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

from wiswarm_apps.tracking import demo
from wiswarm_apps.tracking.report import summarise, write_outputs
from wiswarm_apps.tracking.uav_app import SYSTEMS, System

AOI_TARGET_S = 0.050
ERROR_TARGET_M = 0.4


def verdict(ok: bool) -> str:
    return "met" if ok else "MISSED"


def measure(system: System, args: argparse.Namespace) -> dict[str, Any]:
    options = demo.DemoOptions(
        uavs=args.uavs, duration_s=args.seconds, seed=args.seed, system=system,
        rate_hz=args.push_rate if system == "push" else None, frame_px=224,
        policy=args.policy,
    )
    run = demo.run(options)
    summary = summarise(run)
    if args.out is not None:
        write_outputs(Path(args.out) / system, run, summary)
    processed = sum(v.processed for v in run.vision.values())
    superseded = sum(v.superseded for v in run.vision.values())
    summary["vision_capacity_per_s"] = processed / run.vision_busy_s if run.vision_busy_s else 0
    summary["superseded"] = superseded
    summary["missing"] = sorted(set(options.uav_ids) - set(run.uavs))
    return summary


def report(summary: dict[str, Any]) -> None:
    avg, leader = summary["average"], summary["leader"]
    aoi, error = avg["mean_aoi_s"], avg["mean_tracking_error_m"]
    deliveries, processed = leader["deliveries_per_s"], leader["processed_per_s"]
    capacity = summary["vision_capacity_per_s"]
    print(f"\n{summary['system']}: {summary['uavs']} UAVs, 224x224 frames at "
          f"{summary['rate_hz']:g}/s each, {summary['measured_s']:.0f} s measured")
    if summary["missing"]:
        print(f"  no measurements from {', '.join(summary['missing'])}")
    print(f"  mean AoI           {aoi * 1e3:7.1f} ms   (p95 {avg['p95_aoi_s'] * 1e3:.1f} ms)"
          f"   target <= {AOI_TARGET_S * 1e3:.0f} ms: {verdict(aoi <= AOI_TARGET_S)}")
    print(f"  tracking error     {error:7.3f} m    (p95 {avg['p95_tracking_error_m']:.3f} m,"
          f" car in view {avg['in_view_share'] * 100:.1f}%)"
          f"   target <= {ERROR_TARGET_M} m: {verdict(error <= ERROR_TARGET_M)}")
    print(f"  control age at UAV {avg['mean_control_age_s'] * 1e3:7.1f} ms")
    print(f"  vision             {processed:7.1f} frames/s processed of {deliveries:.1f} "
          f"deliveries/s ({processed / deliveries * 100 if deliveries else 0:.1f}%), "
          f"{summary['superseded']} replaced unprocessed by a newer frame")
    print(f"                     busy {leader['vision_busy_share'] * 100:.0f}% of the time; "
          f"capacity {capacity:.0f} frames/s "
          f"(keeps up: processed >= deliveries {verdict(processed >= deliveries)}, "
          f"capacity >= deliveries {verdict(capacity >= deliveries)})")
    if summary["system"] == "wiswarm":
        print(f"  leader polls       {leader['polls_per_s']:7.0f} /s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--uavs", type=int, default=4)
    parser.add_argument("--seconds", type=float, default=30.0, help="measured per system")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--push-rate", type=float, default=50.0,
                        help="frames/s of the push baseline (the paper's fixed rate: 50)")
    parser.add_argument("--policy", default="whittle")
    parser.add_argument("--systems", nargs="+", choices=SYSTEMS, default=list(SYSTEMS))
    parser.add_argument("--out", default=None, help="also write summary.json and CSVs here")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    for system in SYSTEMS:
        if system in args.systems:
            report(measure(system, args))


if __name__ == "__main__":
    main()
