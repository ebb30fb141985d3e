"""What ``wiswarm demo`` does with its flags (``cli``): each system's run in the same
world, the summaries side by side, the files. Loaded when the demo runs: it is the
application itself (OpenCV, pymavlink: the tracking extra)."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import time
from pathlib import Path

from wiswarm_apps.tracking import demo
from wiswarm_apps.tracking.kinds import SYSTEMS, System
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
from wiswarm_zenoh.dashboard import DEFAULT_PORT
from wiswarm_zenoh.options import UsageError, format_rate, require_testbed, ros2_options
from wiswarm_zenoh.testbed import ChannelSpec, WifiSpec

log = logging.getLogger(__name__)


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
