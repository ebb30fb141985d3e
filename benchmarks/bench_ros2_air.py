"""ROS 2's own routing over the shared air against WiSwarm (issue 33, root, ns-3 for
the WiFi medium): N = 4 and 8 robots, each a Zenoh router of its own with a 30 Hz,
50 kB ``sensor_msgs/msg/CompressedImage`` topic in rmw_zenoh's format, and a ROS 2
subscriber at the ground measuring every robot's frames' age, for (a) subscribing to
the robots' topics directly, (b) the same throttled at the robot to its best rate,
found by the fine search from the medium's share of each robot (golden-section on the
rate, to 5 % or to the next rate the throttle gives of the 30 Hz camera; the report
lists the rates tried), (c) subscribing to ``wiswarm leader --ros2``'s republished
topics (a ``wiswarm follower --ros2-topic`` on each robot), (d) newest-only push
(``wiswarm follower --system push --newest-only --ros2-topic`` on each robot). Over the
20 Mbit/s tbf channel and ns-3's WiFi medium (802.11g). About 13 minutes with the
defaults (about 28 runs).

    flock /tmp/bench.lock .venv/bin/python benchmarks/bench_ros2_air.py \\
        --out runs/ros2-air --figure docs/ros2_air.png
    .venv/bin/python benchmarks/bench_ros2_air.py --ns 4 --media tbf --duration 10
"""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
import time
from pathlib import Path

from wiswarm_zenoh.experiments.ros2_air import MEDIA, AirConfig, CaseResult, run_air
from wiswarm_zenoh.experiments.ros2_air_report import plot, report
from wiswarm_zenoh.programs.zenoh_log import LOG_FORMAT
from wiswarm_zenoh.testbed import check_available


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ns", default="4,8", help="robots per run, comma-separated")
    parser.add_argument("--media", default=",".join(MEDIA), help="tbf, wifi or both")
    parser.add_argument("--duration", type=float, default=20.0, help="window (s)")
    parser.add_argument("--warmup", type=float, default=5.0, help="before the window (s)")
    parser.add_argument("--out", type=Path, help="keep every run's records and the "
                        "report here (default: a temporary directory)")
    parser.add_argument("--figure", type=Path, help="write the figure (PNG) here")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING, format=LOG_FORMAT)
    check_available()
    config = AirConfig(ns=tuple(int(n) for n in args.ns.split(",")),
                       media=tuple(args.media.split(",")), duration=args.duration,
                       warmup=args.warmup)
    began = time.monotonic()

    def progress(run: CaseResult) -> None:
        print(f"{time.monotonic() - began:6.0f} s  {run.medium} N={run.case.n} "
              f"{run.case.label}: mean AoI {run.mean() * 1e3:.0f} ms, "
              f"{run.up_bytes * 8 / run.duration / 1e6:.1f} Mbit/s up", flush=True)

    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        results = run_air(config, out, progress)
        text = report(results)
        (out / "report.md").write_text(text)
    if args.figure is not None:
        plot(args.figure, results)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
