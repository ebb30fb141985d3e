"""``wiswarm demo``: the tracking application end to end (``make demo``).

    wiswarm demo --uavs 4 --duration 30 --seed 0 --system wiswarm --out runs/x
    wiswarm demo --system push --rate 50            # the push baseline at 50 frames/s
    wiswarm demo --channel 20mbit                   # the UAVs behind an emulated channel (root)
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

from apps.tracking import demo
from apps.tracking.plots import write_plots
from apps.tracking.report import summarise, summary_lines, write_outputs
from apps.tracking.uav_app import SYSTEMS
from apps.tracking.vehicles import VEHICLE_KINDS
from apps.tracking.world import MOTIONS
from wiswarm_zenoh.core import POLICIES
from wiswarm_zenoh.dashboard import DEFAULT_PORT
from wiswarm_zenoh.options import (
    RATE,
    SEED,
    TIME,
    ArgType,
    UsageError,
    finite_float,
    positive_float,
    positive_int,
    require_testbed,
    writable_dir,
)
from wiswarm_zenoh.testbed import ChannelSpec, WifiSpec

log = logging.getLogger(__name__)


def _channel(text: str) -> int | str:
    """``wifi``, or a rate in tc's spelling (bits/s)."""
    return "wifi" if text == "wifi" else RATE.parse(text)


CHANNEL = ArgType("channel (a rate or wifi)", _channel)


def add_demo_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--uavs", type=positive_int(), default=4,
                        help="UAVs, one car each (default 4)")
    parser.add_argument("--duration", type=positive_float(), default=30.0,
                        help="seconds measured, after the warm-up (default 30)")
    parser.add_argument("--seed", type=SEED, default=0, help="seed of the world (default 0)")
    parser.add_argument("--system", choices=SYSTEMS, default="wiswarm",
                        help="wiswarm: polled LIFO; push: frames put at --rate into FIFOs")
    parser.add_argument("--rate", type=positive_float(), default=None,
                        help="camera frames/s per UAV (default 100 wiswarm, 50 push)")
    parser.add_argument("--out", type=writable_dir(), default=None, metavar="DIR",
                        help="output directory (default runs/<timestamp>)")
    parser.add_argument("--frame-size", type=int, choices=demo.FRAME_SIZES, default=224,
                        help="square frame side in pixels (224 stationary, 160 flight)")
    parser.add_argument("--vehicle", choices=VEHICLE_KINDS, default="virtual",
                        help="virtual UAVs, or MAVLink to a simulated vehicle on loopback")
    parser.add_argument("--motion", choices=MOTIONS, default="random_walk",
                        help="how the cars drive")
    parser.add_argument("--mode", choices=("peer", "client"), default="peer",
                        help="Zenoh mode of the leader and UAVs (the router is embedded)")
    parser.add_argument("--policy", choices=sorted(POLICIES), default="whittle",
                        help="the leader's polling policy (wiswarm)")
    parser.add_argument("--warmup", type=finite_float(0.0), default=2.0,
                        help="seconds before the cars start, to settle (default 2)")
    parser.add_argument("--channel", type=CHANNEL, metavar="RATE|wifi",
                        help="put the UAVs behind an emulated shared channel of this rate "
                        "each way, e.g. 20mbit, or make each a station of ns-3's 802.11g "
                        "(wifi) (Linux, root: network namespaces and tc tbf or ns-3; "
                        "the UAVs are then Zenoh clients of the leader side's router)")
    parser.add_argument("--channel-queue", type=TIME, default=0.2,
                        metavar="TIME", help="the channel's queue (tbf latency, default 200ms)")
    parser.add_argument("--no-live", action="store_true", help="no live table")
    parser.add_argument("--no-dashboard", action="store_true",
                        help="no live web page (by default the demo serves the dashboard "
                        f"on port {DEFAULT_PORT}, or a free one, and prints its URL; not "
                        "with --channel, where it would listen inside a namespace)")
    parser.add_argument("--no-gif", action="store_true", help="skip the animated GIF")


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``wiswarm demo`` (the tracking application, what ``make demo`` runs)."""
    parser = subparsers.add_parser(
        "demo", help="UAVs tracking cars over Zenoh: live table, summary, plots, GIF",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_demo_arguments(parser)
    parser.set_defaults(func=run_demo)


def options_from(args: argparse.Namespace) -> demo.DemoOptions:
    try:
        channel = (None if args.channel is None else WifiSpec() if args.channel == "wifi"
                   else ChannelSpec(rate_bps=args.channel, queue_s=args.channel_queue))
        return demo.DemoOptions(
            uavs=args.uavs, duration_s=args.duration, seed=args.seed, system=args.system,
            rate_hz=args.rate, frame_px=args.frame_size, vehicle=args.vehicle,
            motion=args.motion, mode=args.mode, policy=args.policy, warmup_s=args.warmup,
            live=not args.no_live, channel=channel,
            dashboard_port=None if args.no_dashboard or channel is not None else DEFAULT_PORT,
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def run_demo(args: argparse.Namespace) -> int:
    """Run, print the summary, write the files; 1 if a UAV handed back nothing."""
    options = options_from(args)
    if options.channel is not None:
        require_testbed()
    out: Path = args.out or Path("runs") / time.strftime("%Y%m%d-%H%M%S")
    run = demo.run(options)
    summary = summarise(run)
    paths = write_outputs(out, run, summary)
    paths += write_plots(out, run, gif=not args.no_gif)
    print("\n".join(summary_lines(summary)))
    print(f"wrote {', '.join(p.name for p in paths)} in {out}")
    missing = sorted(set(options.uav_ids) - set(run.uavs))
    if missing:
        log.error("no measurements from %s", ", ".join(missing))
        return 1
    return 0
