"""What every example shares: the Zenoh flags of zenoh-python's examples (-m, -e, -l,
--no-multicast-scouting), --swarm and --duration, and the session they open."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import threading
import time
from collections.abc import Callable
from typing import NoReturn

import zenoh

from wiswarm_zenoh.programs import exit_without_finalizing

LOCAL_ROUTER = "tcp/127.0.0.1:7447"  # where ``wiswarm router`` listens by default


def parser(description: str) -> argparse.ArgumentParser:
    """An argument parser with the flags every example takes."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("-m", "--mode", choices=["peer", "client"],
                        help="the Zenoh session mode (default: client of the router -e "
                             "names; peer without -e, or with -l)")
    parser.add_argument("-e", "--connect", metavar="ENDPOINT", action="append",
                        help=f"endpoint to connect to (repeatable; default {LOCAL_ROUTER})")
    parser.add_argument("-l", "--listen", metavar="ENDPOINT", action="append",
                        help="endpoint to listen on (repeatable)")
    parser.add_argument("--no-multicast-scouting", action="store_true",
                        help="do not discover peers and routers by multicast")
    parser.add_argument("--swarm", default="swarm", help="the swarm's name (default swarm)")
    parser.add_argument("--duration", type=float, metavar="SECONDS",
                        help="stop after this long (default: at Ctrl-C)")
    return parser


def open_session(args: argparse.Namespace) -> zenoh.Session:
    """A Zenoh session as the flags say."""
    zenoh.init_log_from_env_or("error")
    config = zenoh.Config()
    attached = args.connect and not args.listen  # as wiswarm's own nodes decide
    config.insert_json5("mode", json.dumps(args.mode or ("client" if attached else "peer")))
    config.insert_json5("connect/endpoints", json.dumps(args.connect or [LOCAL_ROUTER]))
    if args.listen:
        config.insert_json5("listen/endpoints", json.dumps(args.listen))
    if args.no_multicast_scouting:
        config.insert_json5("scouting/multicast/enabled", "false")
    # As wiswarm's nodes: a long-running leader would keep every departed follower's
    # shared-memory segments mapped (docs/guides/swarm.md#shared-memory).
    config.insert_json5("transport/shared_memory/enabled", "false")
    return zenoh.open(config)


def end_time(args: argparse.Namespace) -> float:
    """When to stop, on ``time.monotonic``'s clock (infinity: at Ctrl-C)."""
    return math.inf if args.duration is None else time.monotonic() + args.duration


def left(end: float) -> float | None:
    """Seconds to ``end`` (never below 0), or None for no end: a timeout to wait with."""
    return None if end == math.inf else max(0.0, end - time.monotonic())


def wait_until(end: float) -> None:
    """Return at ``end`` (or never: Ctrl-C ends the example)."""
    threading.Event().wait(left(end))


def run(main: Callable[[], None]) -> NoReturn:
    """Run ``main``; Ctrl-C (SIGINT) ends it cleanly, its ``with`` blocks closed. Then
    end the process without the interpreter's finalisation: before Python 3.14, a Zenoh
    thread still calling back into Python then can crash it (``exit_without_finalizing``)."""
    with contextlib.suppress(KeyboardInterrupt):
        main()
    exit_without_finalizing(0)
