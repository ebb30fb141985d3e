"""What ``wiswarm demo`` does with its flags (``cli``): each system's run in the same
world, the summaries side by side, the files, then, with --keep-dashboard, the runs'
dashboards until Ctrl-C. Loaded when the demo runs: it is the application itself
(OpenCV, pymavlink: the tracking extra)."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import threading
import time
from contextlib import ExitStack
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
from wiswarm_zenoh.programs import wait_until_stopped
from wiswarm_zenoh.testbed import ChannelSpec, WifiSpec

log = logging.getLogger(__name__)

LOOK_AFTER = ("to look at a run after it ends: wiswarm demo --keep-dashboard (its dashboard "
              "stays until Ctrl-C), or open its run.mcap in Foxglove")


def options_from(args: argparse.Namespace, system: System = "wiswarm",
                 out: Path | None = None) -> demo.DemoOptions:
    """The run of ``system`` that the flags describe (UsageError if a value is bad);
    with ``out``, the run is recorded to ``out/run.mcap``."""
    no_dashboard = args.no_dashboard or args.channel in ("tbf", "wifi")
    if args.keep_dashboard and no_dashboard:
        raise UsageError("--keep-dashboard needs the dashboard: " + (
            "not with --no-dashboard" if args.no_dashboard
            else f"there is none with --channel {args.channel}"))
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
            dashboard_port=None if no_dashboard else DEFAULT_PORT,
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
    side for several), write the files; with --keep-dashboard, serve the runs'
    dashboards until Ctrl-C. 1 if a UAV handed back nothing."""
    out: Path = args.out or Path("runs") / time.strftime("%Y%m%d-%H%M%S")
    systems = (args.system,) if args.system else SYSTEMS
    where = {system: out if len(systems) == 1 else out / system for system in systems}
    runs = [options_from(args, system, where[system]) for system in systems]
    if args.keep_dashboard:  # the first run's page keeps its port: the others take free ones
        runs[1:] = [dataclasses.replace(options, dashboard_port=0) for options in runs[1:]]
    if runs[0].namespaces:
        require_testbed()
    for directory in where.values():  # each run's recording goes there as it runs
        directory.mkdir(parents=True, exist_ok=True)
    with ExitStack() as pages:  # the runs' dashboards, when they are kept
        kept = pages if args.keep_dashboard else None
        done = (_run_one(runs[0], out, not args.no_gif, kept) if len(runs) == 1
                else _run_all(runs, out, not args.no_gif, kept))
        _look_after(done, kept is not None)
    return _missing(done)


def _run_all(runs: list[demo.DemoOptions], out: Path, gif: bool,
             pages: ExitStack | None) -> list[demo.DemoRun]:
    """Each run in turn (until one is cut short), then the comparison."""
    done: list[demo.DemoRun] = []
    summaries: dict[str, dict[str, object]] = {}
    for k, options in enumerate(runs, 1):
        print(f"run {k} of {len(runs)}: {options.system} at {options.rate:g} frames/s, "
              f"{options.uavs} UAVs, {options.duration_s:g} s over {crossing(options)}",
              flush=True)
        run = demo.run(options, pages)
        summary = summarise(run)
        write_outputs(out / options.system, run, summary)
        write_plots(out / options.system, run, gif=False)
        print("\n".join(summary_lines(summary)), flush=True)
        done.append(run)
        summaries[options.system] = summary
        if _cut_short(run):  # Ctrl-C: no more runs
            break
    comparison = compare(summaries)
    title = f"{runs[0].uavs} UAVs over {crossing(runs[0])}, same world and seed"
    paths = [write_summary(out, comparison), *write_comparison(out, done, title, gif=gif)]
    print(f"\n{title}:")
    print("\n".join(comparison_lines(comparison)))
    print(f"wrote {', '.join(p.name for p in paths)} in {out} (each run's files in "
          f"{', '.join(f'{system}/' for system in summaries)})", flush=True)
    return done


def _run_one(options: demo.DemoOptions, out: Path, gif: bool,
             pages: ExitStack | None) -> list[demo.DemoRun]:
    print(f"{options.system} at {options.rate:g} frames/s, {options.uavs} UAVs, "
          f"{options.duration_s:g} s over {crossing(options)}", flush=True)
    run = demo.run(options, pages)
    summary = summarise(run)
    paths = [*write_outputs(out, run, summary), out / "run.mcap"]
    paths += write_plots(out, run, gif=gif)
    print("\n".join(summary_lines(summary)))
    print(f"wrote {', '.join(p.name for p in paths)} in {out}", flush=True)
    return [run]


def _cut_short(run: demo.DemoRun) -> bool:
    return run.measured_s < run.options.duration_s


def _look_after(done: list[demo.DemoRun], keep: bool) -> None:
    """How to look at the runs now that they are over: with ``keep``, their dashboards,
    still served, until Ctrl-C (not after a Ctrl-C that cut a run short: that one meant
    stop); otherwise one line saying how (when there was a dashboard to keep)."""
    urls = {run.options.system: run.dashboard_url for run in done
            if run.dashboard_url is not None}
    if not urls:
        return
    if not keep:
        print(LOOK_AFTER, flush=True)
        return
    if any(_cut_short(run) for run in done):
        log.info("a run was cut short: its dashboard is not kept")
        return
    where = (next(iter(urls.values())) if len(urls) == 1
             else ", ".join(f"{system} {url}" for system, url in urls.items()))
    print(f"dashboard{'s' if len(urls) > 1 else ''} of the finished "
          f"run{'s' if len(urls) > 1 else ''}: {where} (Ctrl-C to stop)", flush=True)
    wait_until_stopped(threading.Event())


def _missing(runs: list[demo.DemoRun]) -> int:
    """1, with the UAVs named, if any run lacks a UAV's measurements."""
    missing = sorted({f"{run.options.system} {uav}" for run in runs
                      for uav in set(run.options.uav_ids) - set(run.uavs)})
    if missing:
        log.error("no measurements from %s", ", ".join(missing))
        return 1
    return 0
