"""``wiswarm router | leader | follower | swarm-demo``: the middleware's processes.

``--system push|udp|tcp`` turns a follower into a baseline a Zenoh user would pick
instead of polling (frames pushed at a fixed rate, or with ``--newest-only`` each
frame sent once the previous send completed) and a leader into its receiver, which
publishes the same stats as the polling leader.

Zenoh flags follow zenoh-python's examples (-m/-e/-l/-c/--cfg/--no-multicast-scouting).
Without -e or -c, leader and follower connect to a router on this machine
(``wiswarm router``, tcp/127.0.0.1:7447) as peers; given -e (and no -l), they are
clients of the router it names (``zenoh_config.ATTACHED_MODE`` says why).
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
from pathlib import Path
from typing import Any

from wiswarm_zenoh.cli.follower_command import register_follower
from wiswarm_zenoh.cli.leader_command import register_leader
from wiswarm_zenoh.cli.node_flags import (
    DEFAULT_SWARM,
    Announce,
    add_common,
    check_frame_bytes,
    session_spec,
)
from wiswarm_zenoh.core import POLICIES, FollowerConfig
from wiswarm_zenoh.options import positive_float, positive_int, writable_dir
from wiswarm_zenoh.programs.demo import DemoOptions, run_demo
from wiswarm_zenoh.programs.frames import FRAME_BYTES, FRAME_RATE
from wiswarm_zenoh.programs.runners import run_router
from wiswarm_zenoh.programs.ticker import MAX_RATE_HZ
from wiswarm_zenoh.transport.zenoh_config import MODES, SessionSpec

__all__ = ["DEFAULT_SWARM", "register"]


def _listening(spec: SessionSpec) -> list[str]:
    """Where a router listens: its flags, else its config file, else Zenoh's default
    (a map by mode when nothing was set)."""
    endpoints = json.loads(spec.config().get_json("listen/endpoints"))
    return list(endpoints["router"] if isinstance(endpoints, dict) else endpoints)


def _router(args: argparse.Namespace) -> int:
    spec = session_spec(args, "router")
    where = ", ".join(_listening(spec))
    # Where access control runs: what it refuses shows at the default level.
    run_router(spec, threading.Event(),
               Announce(f"wiswarm router: listening on {where} (Ctrl-C to stop)"), args.duration,
               log_verbosity=args.verbose)
    return 0


def _demo(args: argparse.Namespace) -> int:
    check_frame_bytes(args.frame_bytes, FollowerConfig())
    run_dir = run_demo(DemoOptions(args.followers, args.duration, args.policy,
                                   args.frame_bytes, args.rate, str(args.out)))
    print(f"run directory: {run_dir}", file=sys.stdout)
    return 0


def register(subparsers: Any) -> None:
    router = subparsers.add_parser("router", help="a Zenoh router (default: tcp/[::]:7447)")
    add_common(router, MODES)
    router.set_defaults(func=_router)
    register_leader(subparsers)
    register_follower(subparsers)

    demo = subparsers.add_parser(
        "swarm-demo", help="router + leader + synthetic followers, live table and plots"
    )
    demo.add_argument("--followers", type=positive_int(), default=6,
                      help="synthetic followers (default 6)")
    demo.add_argument("--duration", type=positive_float(), default=20.0, metavar="SECONDS",
                      help="how long the demo runs (default 20)")
    demo.add_argument("--policy", default="whittle", choices=sorted(POLICIES),
                      help="the leader's polling policy (default whittle)")
    demo.add_argument("--frame-bytes", type=positive_int(), default=FRAME_BYTES,
                      help=f"bytes per synthetic frame (default {FRAME_BYTES})")
    demo.add_argument("--rate", type=positive_float(MAX_RATE_HZ), default=FRAME_RATE,
                      help="frames/s")
    demo.add_argument("--out", default=Path("runs"), type=writable_dir(), metavar="DIR",
                      help="where run directories go (default runs)")
    demo.set_defaults(func=_demo, needs="plots")
