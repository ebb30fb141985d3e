"""``wiswarm demo``: the tracking application end to end (``make demo``).

By default WiSwarm and then the push baseline (50 frames/s) fly the same world, each
over a 20 Mbit/s shared link in user space (no root), and the two are compared:

    wiswarm demo                                    # both, side by side
    wiswarm demo --system push                      # one of them
    wiswarm demo --channel none                     # on bare loopback (nothing scarce)
    wiswarm demo --channel tbf --channel-rate 5mbit # namespaces and tc tbf (root)
    wiswarm demo --channel wifi                     # each UAV an ns-3 802.11g station (root)
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import time
from pathlib import Path

from wiswarm_apps.tracking import demo
from wiswarm_apps.tracking.plots import write_comparison, write_plots
from wiswarm_apps.tracking.report import (
    compare,
    comparison_lines,
    summarise,
    summary_lines,
    write_outputs,
    write_summary,
)
from wiswarm_apps.tracking.ros2 import FrameAdapter
from wiswarm_apps.tracking.uav_app import SYSTEMS, System
from wiswarm_apps.tracking.vehicles import VEHICLE_KINDS
from wiswarm_apps.tracking.world import MOTIONS
from wiswarm_zenoh.core import POLICIES
from wiswarm_zenoh.dashboard import DEFAULT_PORT
from wiswarm_zenoh.options import (
    RATE,
    SEED,
    TIME,
    ArgType,
    UsageError,
    add_ros2_arguments,
    finite_float,
    format_rate,
    positive_float,
    positive_int,
    require_testbed,
    ros2_options,
    writable_dir,
)
from wiswarm_zenoh.testbed import ChannelSpec, WifiSpec

CHANNELS = ("user", "tbf", "wifi", "none")


def _channel(text: str) -> str:
    if text not in CHANNELS:
        raise ValueError(f"{text[:60]!r} is not one of {', '.join(CHANNELS)} (a rate goes "
                         "in --channel-rate)")
    return text


log = logging.getLogger(__name__)


def add_demo_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--uavs", type=positive_int(), default=4,
                        help="UAVs, one car each (default 4)")
    parser.add_argument("--duration", type=positive_float(), default=30.0,
                        help="seconds measured, after the warm-up (default 30)")
    parser.add_argument("--seed", type=SEED, default=0, help="seed of the world (default 0)")
    parser.add_argument("--system", choices=SYSTEMS, default=None,
                        help="run one: wiswarm (polled LIFO) or push (frames put at --rate "
                        "into FIFOs); default both, one after the other, compared")
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
                        help="Zenoh mode of the leader and UAVs on bare loopback (the "
                        "router is embedded); across a channel the UAVs are its clients")
    parser.add_argument("--policy", choices=sorted(POLICIES), default="whittle",
                        help="the leader's polling policy (wiswarm)")
    parser.add_argument("--warmup", type=finite_float(0.0), default=2.0,
                        help="seconds before the cars start, to settle (default 2)")
    parser.add_argument("--channel", type=ArgType("channel", _channel), default="user",
                        help="what the UAVs' traffic to the leader crosses: user (default), a "
                        "shared link in user space (a relay on loopback with one token bucket "
                        "and FIFO per direction; no root); tbf, network namespaces and tc "
                        "tbf (Linux, root); wifi, each UAV a station of ns-3's 802.11g "
                        "(Linux, root, ns-3; --channel-rate does not apply); none, bare "
                        "loopback (nothing scarce)")
    parser.add_argument("--channel-rate", type=RATE, default=20_000_000, metavar="RATE",
                        help="the channel's rate each way, in tc's spelling (default 20mbit)")
    parser.add_argument("--channel-queue", type=TIME, default=0.2,
                        metavar="TIME", help="the channel's queue (tbf latency, default 200ms)")
    parser.add_argument("--no-live", action="store_true", help="no live table")
    parser.add_argument("--no-dashboard", action="store_true",
                        help="no live web page (by default the demo serves the dashboard "
                        f"on port {DEFAULT_PORT}, or a free one, and prints its URL, and "
                        "serves the run live to Foxglove beside it; not with --channel "
                        "tbf or wifi, where they would listen inside a namespace)")
    parser.add_argument("--no-gif", action="store_true", help="skip the animated GIF")
    add_ros2_arguments(parser)  # the demo's adapter by default: frames as images, poses


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``wiswarm demo`` (the tracking application, what ``make demo`` runs)."""
    parser = subparsers.add_parser(
        "demo", help="UAVs tracking cars over Zenoh: live table, summary, plots, GIF",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_demo_arguments(parser)
    parser.set_defaults(func=run_demo)


def options_from(args: argparse.Namespace, system: System = "wiswarm",
                 out: Path | None = None) -> demo.DemoOptions:
    """The run of ``system`` that the flags describe (UsageError if a value is bad);
    with ``out``, the run is recorded to ``out/run.mcap``."""
    try:
        channel = (None if args.channel == "none" else WifiSpec() if args.channel == "wifi"
                   else ChannelSpec(rate_bps=args.channel_rate, queue_s=args.channel_queue))
        system = args.system or system
        ros2 = ros2_options(args) if system == "wiswarm" else None
        if ros2 is not None and ros2.adapter is None:
            ros2 = dataclasses.replace(ros2, adapter=FrameAdapter())
        return demo.DemoOptions(
            uavs=args.uavs, duration_s=args.duration, seed=args.seed,
            system=system, rate_hz=args.rate, frame_px=args.frame_size,
            vehicle=args.vehicle, motion=args.motion, mode=args.mode, policy=args.policy,
            warmup_s=args.warmup, live=not args.no_live, channel=channel,
            channel_kind="user" if args.channel == "none" else args.channel, ros2=ros2,
            mcap=None if out is None else out / "run.mcap",
            dashboard_port=(None if args.no_dashboard or args.channel in ("tbf", "wifi")
                            else DEFAULT_PORT),
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def crossing(options: demo.DemoOptions) -> str:
    """What the run's traffic crosses, for people."""
    spec = options.channel
    if spec is None:
        return "bare loopback (nothing scarce)"
    if isinstance(spec, WifiSpec):
        return f"the WiFi medium, a station per UAV ({spec.describe()})"
    kind = ("shared link in user space" if options.channel_kind == "user"
            else "tbf channel between network namespaces")
    return f"a {format_rate(spec.rate_bps)} {kind} ({spec.queue_s * 1e3:g} ms queue)"


def run_demo(args: argparse.Namespace) -> int:
    """Run one system, or each in turn in the same world; print the summary (side by
    side for several), write the files; 1 if a UAV handed back nothing."""
    out: Path = args.out or Path("runs") / time.strftime("%Y%m%d-%H%M%S")
    systems = (args.system,) if args.system else SYSTEMS
    where = {system: out if len(systems) == 1 else out / system for system in systems}
    runs = [options_from(args, system, where[system]) for system in systems]
    if runs[0].namespaces:
        require_testbed()
    for directory in where.values():  # each run's recording goes there as it runs
        directory.mkdir(parents=True, exist_ok=True)
    if len(runs) == 1:
        return _run_one(runs[0], out, gif=not args.no_gif)
    done: list[demo.DemoRun] = []
    summaries: dict[str, dict[str, object]] = {}
    for k, options in enumerate(runs, 1):
        print(f"run {k} of {len(runs)}: {options.system} at {options.rate:g} frames/s, "
              f"{options.uavs} UAVs, {options.duration_s:g} s over {crossing(options)}",
              flush=True)
        run = demo.run(options)
        summary = summarise(run)
        write_outputs(out / options.system, run, summary)
        write_plots(out / options.system, run, gif=False)
        print("\n".join(summary_lines(summary)), flush=True)
        done.append(run)
        summaries[options.system] = summary
        if run.measured_s < options.duration_s:  # cut short (Ctrl-C): no more runs
            break
    comparison = compare(summaries)
    title = f"{runs[0].uavs} UAVs over {crossing(runs[0])}, same world and seed"
    paths = [write_summary(out, comparison),
             *write_comparison(out, done, title, gif=not args.no_gif)]
    print(f"\n{title}:")
    print("\n".join(comparison_lines(comparison)))
    print(f"wrote {', '.join(p.name for p in paths)} in {out} (each run's files in "
          f"{', '.join(f'{system}/' for system in summaries)})")
    return _missing(done)


def _run_one(options: demo.DemoOptions, out: Path, gif: bool) -> int:
    print(f"{options.system} at {options.rate:g} frames/s, {options.uavs} UAVs, "
          f"{options.duration_s:g} s over {crossing(options)}", flush=True)
    run = demo.run(options)
    summary = summarise(run)
    paths = [*write_outputs(out, run, summary), out / "run.mcap"]
    paths += write_plots(out, run, gif=gif)
    print("\n".join(summary_lines(summary)))
    print(f"wrote {', '.join(p.name for p in paths)} in {out}")
    return _missing([run])


def _missing(runs: list[demo.DemoRun]) -> int:
    """1, with the UAVs named, if any run lacks a UAV's measurements."""
    missing = sorted({f"{run.options.system} {uav}" for run in runs
                      for uav in set(run.options.uav_ids) - set(run.uavs)})
    if missing:
        log.error("no measurements from %s", ", ".join(missing))
        return 1
    return 0
