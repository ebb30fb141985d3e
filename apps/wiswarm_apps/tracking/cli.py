"""``wiswarm demo`` and ``wiswarm experiment tracking``: the tracking application's
commands. Registering them loads no more than their flags: the application (OpenCV,
pymavlink: the tracking extra) loads when one runs.

``wiswarm demo`` runs the application end to end (``make demo``).

By default WiSwarm and then the push baseline (50 frames/s) fly the same world, each
over a 20 Mbit/s shared link in user space (no root), and the two are compared:

    wiswarm demo                                    # both, side by side
    wiswarm demo --system push                      # one of them
    wiswarm demo --channel none                     # on bare loopback (nothing scarce)
    wiswarm demo --channel tbf --channel-rate 5mbit # namespaces and tc tbf (root)
    wiswarm demo --channel wifi                     # each UAV an ns-3 802.11g station (root)
    wiswarm demo --keep-dashboard                   # then each run's page stays until Ctrl-C

The dashboard (and Foxglove's live server) show a run while it lasts; to look at runs
once they have ended, --keep-dashboard keeps each run's dashboard serving the run's last
state until Ctrl-C, and every run is recorded to its run.mcap, which Foxglove opens.
"""

from __future__ import annotations

import argparse
from typing import Any

from wiswarm_apps.tracking.kinds import FRAME_SIZES, SYSTEMS, VEHICLE_KINDS
from wiswarm_apps.tracking.world import MOTIONS
from wiswarm_zenoh.core import POLICIES
from wiswarm_zenoh.dashboard import DEFAULT_PORT
from wiswarm_zenoh.options import (
    COUNTS,
    RATE,
    SEED,
    TIME,
    ArgType,
    add_channel_arguments,
    add_rate_grid,
    add_ros2_arguments,
    finite_float,
    positive_float,
    positive_int,
    writable_dir,
)

CHANNELS = ("user", "tbf", "wifi", "none")


def _channel(text: str) -> str:
    if text not in CHANNELS:
        raise ValueError(f"{text[:60]!r} is not one of {', '.join(CHANNELS)} (a rate goes "
                         "in --channel-rate)")
    return text


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
    parser.add_argument("--frame-size", type=int, choices=FRAME_SIZES, default=224,
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
    parser.add_argument("--keep-dashboard", action="store_true",
                        help="once the runs are over and the summary printed, keep serving "
                        "each run's dashboard, frozen at the run's end, until Ctrl-C (it "
                        "prints where); the first run keeps its port, later runs take "
                        "free ones. Foxglove's live server is not kept (it has no history "
                        "for a latecomer): open the run's run.mcap in Foxglove instead")
    parser.add_argument("--no-gif", action="store_true", help="skip the animated GIF")
    add_ros2_arguments(parser)  # the demo's adapter by default: frames as images, poses


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``wiswarm demo`` (the tracking application, what ``make demo`` runs)."""
    parser = subparsers.add_parser(
        "demo", help="UAVs tracking cars over Zenoh: live table, summary, plots, GIF",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_demo_arguments(parser)
    parser.set_defaults(func=_demo, needs="tracking")


def _demo(args: argparse.Namespace) -> int:
    from wiswarm_apps.tracking.demo_runs import run_demo  # the application itself

    return run_demo(args)


STUDY = """The paper's flight study (Figs. 8/9) on real processes, the UAVs behind the
emulated channel.

For every N: the tracking demo with WiSwarm, with push at the fixed rate (50 fps) and
with push at its best rate of the paper's grid, chosen as the paper chose it, by
tracking error (the same search as the stationary study's, from the channel's share of
each UAV). Runs go one at a time: the leader's vision is what uses the CPU. Writes
``runs.csv``, ``tracking_error.png``, ``aoi.png`` and ``tracking.md``.
"""


def register_tracking(studies: Any) -> None:
    """Add ``experiment tracking`` to the ``experiment`` group."""
    parser = studies.add_parser(
        "tracking", help="the flight study: tracking error and AoI against N over a channel",
        description=STUDY, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ns", type=COUNTS, default=(1, 2, 3, 4, 5),
                        help="numbers of UAVs (default 1,2,3,4,5)")
    add_rate_grid(parser, "push's")
    parser.add_argument("--duration", type=positive_float(), default=20.0,
                        help="seconds measured per run (default 20)")
    parser.add_argument("--seed", type=SEED, default=0, help="seed of the world (default 0)")
    parser.add_argument("--frame-size", type=int, choices=FRAME_SIZES, default=224,
                        help="square frame side in pixels (default 224)")
    parser.add_argument("--out", type=writable_dir(), metavar="DIR",
                        help="output directory (runs/tracking-<timestamp>)")
    add_channel_arguments(parser)
    parser.set_defaults(func=_tracking, needs="tracking")


def _tracking(args: argparse.Namespace) -> int:
    from wiswarm_apps.tracking.study import run_tracking  # the application itself

    return run_tracking(args)


