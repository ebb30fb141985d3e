"""``wiswarm experiment sweep|testbed|...``: the paper's experiments.

The group gathers studies from several modules (the simulator's sweep, the testbed's
study here, the tracking application's flights, the edge-cloud runs), each adding its
parser through a ``register_*(studies)`` function.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from wiswarm_zenoh.dashboard.live_points import add_live_arguments, open_live, study_by_n
from wiswarm_zenoh.experiments.sweep import PAPER_NS, PAPER_RATES
from wiswarm_zenoh.experiments.testbed_study import BASELINES, StudyConfig, run_study
from wiswarm_zenoh.experiments.testbed_study_report import write_study
from wiswarm_zenoh.options import (
    COUNTS,
    OneLineParser,
    ProgressBar,
    UsageError,
    add_channel_arguments,
    add_medium_arguments,
    add_rate_grid,
    channel_spec,
    finite_float,
    listed,
    one_of,
    positive_float,
    positive_int,
    require_testbed,
    show_written,
    wifi_spec,
    writable_dir,
)
from wiswarm_zenoh.programs.frames import FRAME_BYTES
from wiswarm_zenoh.units import format_rate


def register(subparsers: Any) -> None:
    """Add ``experiment`` and every study under it."""
    from wiswarm_apps.tracking.cli import register_tracking
    from wiswarm_zenoh.cli.edge_cloud import register_edge_cloud
    from wiswarm_zenoh.cli.mission import register_mission
    from wiswarm_zenoh.cli.sim import register_sweep

    experiment = subparsers.add_parser("experiment", help="reproduce the paper's experiments")
    studies = experiment.add_subparsers(dest="study", metavar="STUDY", parser_class=OneLineParser)
    studies.required = True
    for register_study in (register_sweep, register_testbed, register_tracking,
                           register_edge_cloud, register_mission):
        register_study(studies)


def add_study_arguments(parser: argparse.ArgumentParser, ns: tuple[int, ...],
                        duration: float, warmup: float) -> None:
    """The stationary study's size and systems (--ns, --baselines, --duration, --warmup),
    with these defaults: for ``experiment testbed`` and the benchmarks that run it."""
    parser.add_argument("--ns", type=COUNTS, default=ns,
                        help=f"numbers of UAVs (default {','.join(map(str, ns))})")
    parser.add_argument("--baselines", type=listed(one_of(BASELINES), ",".join(BASELINES)),
                        default=BASELINES,
                        help=f"comma-separated, of {', '.join(BASELINES)} (default all)")
    parser.add_argument("--duration", type=positive_float(), default=duration,
                        help=f"seconds measured per run (default {duration:g}; the paper: 240)")
    parser.add_argument("--warmup", type=finite_float(0.0), default=warmup,
                        help=f"seconds before each run's window opens (default {warmup:g})")


def _study_config(args: argparse.Namespace) -> StudyConfig:
    if args.rates is not None and args.search != "grid":
        raise UsageError("--rates is the grid of --search grid: give both, or neither")
    try:
        return StudyConfig(
            ns=args.ns, baselines=args.baselines, search=args.search,
            rates=args.rates or PAPER_RATES, fixed_rate=args.fixed_rate, batches=args.batches,
            duration=args.duration, warmup=args.warmup, frame_bytes=args.frame_bytes,
            channel=channel_spec(args), medium=wifi_spec(args, max(args.ns)),
            parallel=args.parallel or (1 if args.medium == "wifi" else 2),
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _testbed(args: argparse.Namespace) -> int:
    config = _study_config(args)
    require_testbed()
    out: Path = args.out or Path("runs") / time.strftime("testbed-%Y%m%d-%H%M%S")
    (out / "records").mkdir(parents=True, exist_ok=True)
    ch = config.channel
    media = (f"channel(s) of {format_rate(ch.rate_bps)} up / {format_rate(ch.down_bps)} "
             f"down, {ch.queue_s * 1e3:g} ms queue" if config.medium is None else
             f"WiFi medium(s), {config.medium.describe()}")
    print(f"testbed: {config.parallel} {media}; N in "
          f"{', '.join(map(str, config.ns))}; about {config.estimated_runs} runs of "
          f"{config.warmup + config.duration:g} s; output in {out}", file=sys.stderr)
    bar = ProgressBar("testbed")
    with open_live(args, out, "testbed", config.baselines, config.fixed_rate) as live:
        results = run_study(config, out / "records", bar) if live is None else study_by_n(
            config, lambda part, progress: run_study(part, out / "records", progress), bar,
            live)
    return show_written(write_study(out, config, results), results.interrupted)


def register_testbed(studies: Any) -> None:
    """Add ``experiment testbed`` to the ``experiment`` group's subparsers."""
    testbed = studies.add_parser(
        "testbed", help="the stationary study on real processes over an emulated channel",
        description="WiSwarm against the push baselines (Zenoh put, UDP, TCP) over a tbf-"
        "shaped channel between network namespaces, or ns-3's WiFi (--medium wifi) (Linux, "
        "root): for each N, WiSwarm, each "
        "baseline at --fixed-rate and at its best rate (found by --search: finely from the "
        "channel's share, or on the paper's grid). "
        "Writes CSVs, figures with the simulator's model of the channel beside, gains.md.")
    add_study_arguments(testbed, PAPER_NS, duration=30.0, warmup=5.0)
    add_rate_grid(testbed, "the baselines'", searched="--search grid's rates")
    testbed.add_argument("--batches", type=positive_int(), default=1,
                         help="batches per point (default 1; the paper: 4)")
    testbed.add_argument("--frame-bytes", type=positive_int(), default=FRAME_BYTES,
                         help=f"bytes per camera frame (default {FRAME_BYTES} = 224x224)")
    testbed.add_argument("--parallel", type=positive_int(),
                         help="runs at once, each on a channel of its own (default 2; 1 for "
                              "the WiFi medium, whose real time needs a core)")
    testbed.add_argument("--out", type=writable_dir(), metavar="DIR",
                         help="output directory (runs/testbed-<timestamp>)")
    add_channel_arguments(testbed)
    add_medium_arguments(testbed, stations=False)
    add_live_arguments(testbed)
    testbed.set_defaults(func=_testbed, needs="plots")
