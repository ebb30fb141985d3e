"""``wiswarm experiment mission``: WiSwarm against what a ROS 2 team would run instead
(its own routing, a throttle tuned finely, newest-only push) while the swarm changes
under them: robots join and leave, a link degrades, a weight moves (Linux, root)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from wiswarm_zenoh.experiments.mission import LABELS, SYSTEMS, MissionConfig
from wiswarm_zenoh.experiments.mission_scenario import mission_named, shipped_text
from wiswarm_zenoh.experiments.ros2_air import MEDIA
from wiswarm_zenoh.options import (
    ArgType,
    UsageError,
    listed,
    one_of,
    positive_float,
    require_testbed,
    writable_dir,
)

STANDARD = "standard"
MISSION = ArgType("mission", mission_named)


def _run(args: argparse.Namespace) -> int:
    if args.show_scenario:
        print(shipped_text(STANDARD), end="")
        return 0
    from wiswarm_zenoh.experiments.mission_report import plot, report
    from wiswarm_zenoh.experiments.mission_study import run_study
    from wiswarm_zenoh.experiments.rate_search import fine_search

    try:
        config = MissionConfig(args.scenario, media=args.media, systems=args.systems,
                               warmup=args.warmup, tune_seconds=args.tune_seconds)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    require_testbed()
    out: Path = args.out or Path("runs") / time.strftime("mission-%Y%m%d-%H%M%S")
    (out / "records").mkdir(parents=True, exist_ok=True)
    mission = config.mission
    print(f"mission {mission.name!r}: {len(mission.phases)} phases, "
          f"{mission.duration:g} s, robots {len(mission.robots)}; "
          f"{', '.join(config.systems)} on {', '.join(config.media)}; output in {out}",
          file=sys.stderr)
    began = time.monotonic()

    def progress(text: str) -> None:
        print(f"{time.monotonic() - began:6.0f} s  {text}", file=sys.stderr, flush=True)

    results = run_study(config, out / "records", fine_search, progress)
    text = report(results)
    (out / "report.md").write_text(text)
    plot(out / "mission.png", results)
    print(out / "mission.png")
    print(out / "report.md")
    print(text, end="")
    return 0


def register_mission(studies: Any) -> None:
    """Add ``experiment mission`` to the ``experiment`` group's subparsers."""
    parser = studies.add_parser(
        "mission", help="the swarm changes under the network: WiSwarm against a tuned "
        "throttle, newest-only push and ROS 2's routing (root)",
        description="Robots as ROS 2 nodes (a Zenoh router each, a 30 Hz 50 kB camera "
        "topic in rmw_zenoh's format) fly a mission of phases over the testbed's tbf "
        "channel and ns-3's WiFi medium: robots join and leave, a robot's link "
        "degrades, a robot's weight rises. Each system flies it once: "
        + "; ".join(f"{s}: {LABELS[s]}" for s in SYSTEMS) + ". The fixed rates are "
        "tuned first by short static runs of a phase (the fine search; kept in "
        "records/tuned.json and reused by a later run with the same --out; so are the runs "
        "flown there, reported with the new ones: fly it system by system, or go on "
        "after a stop). Writes "
        "report.md (per phase and whole: mean, p95 and weighted mean AoI, bytes) and "
        "mission.png (AoI against time). The standard mission (4 minutes per system "
        "and medium, about an hour in all with the tuning) is --show-scenario's.")
    parser.add_argument("--scenario", type=MISSION, default=STANDARD, metavar="FILE",
                        help="a mission TOML file, or standard (default) or small")
    parser.add_argument("--show-scenario", action="store_true",
                        help="print the standard mission's file (to copy and change) and exit")
    parser.add_argument("--media", type=listed(one_of(MEDIA), "tbf,wifi"), default=MEDIA,
                        help="tbf, wifi or both (default both)")
    parser.add_argument("--systems", type=listed(one_of(SYSTEMS), "wiswarm,oracle"),
                        default=SYSTEMS, help=f"of {', '.join(SYSTEMS)} (default all)")
    parser.add_argument("--warmup", type=positive_float(), default=10.0,
                        help="seconds from the first process to the mission's start "
                        "(default 10)")
    parser.add_argument("--tune-seconds", type=positive_float(), default=15.0,
                        help="each tuning run's window (default 15)")
    parser.add_argument("--out", type=writable_dir(), metavar="DIR",
                        help="output directory (runs/mission-<timestamp>)")
    parser.set_defaults(func=_run, needs="plots")
