"""``wiswarm experiment edge-cloud``: sites and a cloud joined by a WAN (Linux, root),
polled directly from the cloud, through edge leaders, and by the edges alone."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from wiswarm_zenoh.experiments.edge_cloud_report import write_all
from wiswarm_zenoh.experiments.edge_cloud_run import (
    MAX_FOLLOWERS,
    EdgeCloudConfig,
    run_edge_cloud,
)
from wiswarm_zenoh.experiments.edge_cloud_topology import MAX_SITES, WanSpec
from wiswarm_zenoh.options import (
    IN_FLIGHTS,
    RATE,
    TIME,
    ProgressBar,
    UsageError,
    add_channel_arguments,
    channel_spec,
    positive_float,
    positive_int,
    require_testbed,
    show_written,
    writable_dir,
)
from wiswarm_zenoh.programs.frames import FRAME_BYTES
from wiswarm_zenoh.units import format_rate

# The fields a config names in its errors, as the flags the user wrote.
FLAGS = {"rate_bps": "--wan", "delay_s": "--delay", "in_flight": "--in-flight",
         "frame_bytes": "--frame-bytes"}


def _flag_error(exc: ValueError) -> UsageError:
    field, _, rest = str(exc).partition(" ")
    return UsageError(f"{FLAGS.get(field, field)} {rest}")


def edge_cloud_config(args: argparse.Namespace) -> EdgeCloudConfig:
    """The experiment the flags describe (UsageError, one line, if they do not fit)."""
    local = channel_spec(args)
    try:
        wan = WanSpec(rate_bps=args.wan, delay_s=args.delay)
        return EdgeCloudConfig(
            sites=args.sites, followers=args.followers, local=local, wan=wan,
            in_flight=args.in_flight, duration=args.duration, warmup=args.warmup,
            frame_bytes=args.frame_bytes, secure=args.secure)
    except ValueError as exc:
        raise _flag_error(exc) from None


def _edge_cloud(args: argparse.Namespace) -> int:
    config = edge_cloud_config(args)
    require_testbed()
    out: Path = args.out or Path("runs") / time.strftime("edge-cloud-%Y%m%d-%H%M%S")
    setups = config.setups()
    print(f"edge-cloud: {config.sites} sites x {config.followers} followers on "
          f"{format_rate(config.local.rate_bps)} channels, WAN "
          f"{format_rate(config.wan.rate_bps)} and {config.wan.delay_s * 1e3:g} ms"
          f"{', closed' if config.secure else ''}; "
          f"{', '.join(s.label for s in setups)}; {len(setups)} runs of about "
          f"{config.warmup + config.duration:g} s; output in {out}", file=sys.stderr)
    results = run_edge_cloud(config, out / "records", ProgressBar("edge-cloud"))
    return show_written(write_all(out, results), results.interrupted)


def register_edge_cloud(studies: Any) -> None:
    """Add ``experiment edge-cloud`` to the ``experiment`` group's subparsers."""
    parser = studies.add_parser(
        "edge-cloud", help="edge leaders under a cloud leader, over an emulated WAN (root)",
        description="Sites, each a shared channel with its router, joined to a cloud "
        "router by WAN links (tc tbf each way, a relay for the one-way delay); compares "
        "the cloud polling every follower directly, the hierarchy (edge leaders with "
        "--upstream, the cloud leader on the parent swarm), and the edge leaders alone. "
        "Writes pairs.csv, summary.csv, aoi.png and report.md (Linux, root).")
    parser.add_argument("--sites", type=positive_int(MAX_SITES), default=2,
                        help="sites, each a channel and an edge leader (default 2)")
    parser.add_argument("--followers", type=positive_int(MAX_FOLLOWERS), default=6,
                        help="followers per site (default 6)")
    parser.add_argument("--wan", type=RATE, default=50_000_000, metavar="RATE",
                        help="the WAN links' rate each way, e.g. 50mbit (default 50mbit)")
    parser.add_argument("--delay", type=TIME, default=0.02, metavar="TIME",
                        help="the WAN's one-way delay, e.g. 20ms (default 20ms)")
    parser.add_argument("--in-flight", type=IN_FLIGHTS, metavar="K,K",
                        help="hierarchies to run, by the polls the cloud leader keeps in "
                        "flight on the WAN, e.g. 1,6,auto (default: 1, the number that keeps "
                        "the WAN busy, (2 delay + frame time) / frame time, one per pair, "
                        "and auto: the leader finds it)")
    parser.add_argument("--duration", type=positive_float(), default=15.0,
                        help="seconds measured per setup (default 15)")
    parser.add_argument("--warmup", type=positive_float(), default=5.0,
                        help="seconds before each window opens, counted from the moment "
                        "every pair was delivered (default 5)")
    parser.add_argument("--frame-bytes", type=positive_int(), default=FRAME_BYTES,
                        help=f"bytes per camera frame (default {FRAME_BYTES} = 224x224)")
    parser.add_argument("--secure", action="store_true",
                        help="run closed: every node with its own certificate over TLS, "
                        "every router with its access control, as wiswarm security init "
                        "--site writes them (no direct setup: the cloud polls the edges only)")
    parser.add_argument("--out", type=writable_dir(), metavar="DIR",
                        help="output directory (runs/edge-cloud-<timestamp>)")
    add_channel_arguments(parser)
    parser.set_defaults(func=_edge_cloud, needs="plots")
