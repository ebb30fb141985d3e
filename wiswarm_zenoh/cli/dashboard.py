"""``wiswarm dashboard``: a live web page of a swarm, from its key expressions only.

Like the other nodes it connects to a router on this machine (tcp/127.0.0.1:7447) as a
peer unless -e or -c says otherwise; it only subscribes, so it never slows the swarm.
"""

from __future__ import annotations

import argparse
import ipaddress
import socket
import threading
from typing import Any

from wiswarm_zenoh.cli.nodes import DEFAULT_SWARM
from wiswarm_zenoh.dashboard import DEFAULT_HOST, DEFAULT_PORT, Dashboard
from wiswarm_zenoh.options import (
    ArgType,
    UsageError,
    add_zenoh_arguments,
    integer,
    node_name,
    positive_float,
)
from wiswarm_zenoh.programs.runners import wait_until_stopped
from wiswarm_zenoh.transport.zenoh_config import LOCAL_ROUTER, SessionSpec


def _address(text: str) -> str:
    """An IP address to serve on (not a host name: it says which interface)."""
    try:
        ipaddress.ip_address(text)
    except ValueError:
        raise ValueError(f"expected an IP address like 127.0.0.1, 0.0.0.0 or ::, "
                         f"got {text[:60]!r}") from None
    return text


ADDRESS = ArgType("address", _address)


def _port_free(host: str, port: int) -> None:
    """OSError if ``port`` cannot be listened on: found at once, not after the session's
    scouting (seconds) as when the page's server finds it."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        probe.bind((host, port))


def serve(spec: SessionSpec, swarm: str, port: int, host: str) -> Dashboard:
    """The dashboard, or the reason it cannot listen as one line."""
    try:
        _port_free(host, port)
        return Dashboard.open(spec, swarm, port, host)
    except OSError as exc:
        raise UsageError(f"cannot serve on {host} port {port}: "
                         f"{exc.strerror or exc}") from None


def _dashboard(args: argparse.Namespace) -> int:
    spec = SessionSpec.from_args(args, "peer", (LOCAL_ROUTER,))
    spec.config()  # every flag checked before anything starts
    dashboard = serve(spec, args.swarm, args.port, args.host)
    try:
        print(f"wiswarm dashboard: swarm {args.swarm!r} on {dashboard.url} (Ctrl-C to stop)",
              flush=True)
        wait_until_stopped(threading.Event(), args.duration)
    finally:
        dashboard.close()
    return 0


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "dashboard", help="a live web page of a swarm: AoI sawtooth, stats, map, experiments",
        description="Serves a web page that shows a swarm live, from Zenoh subscriptions "
        "only: the exact AoI sawtooth of every follower over the last 30 s (from "
        "wiswarm/<swarm>/leader/deliveries, unanswered polls marked), a table of the "
        "leader's stats per follower and who leads, the tracking demo's arena "
        "(wiswarm/<swarm>/<uav>/tracking) and experiments run with --live "
        "(wiswarm/experiments/<run>/points). Open the URL it prints in a browser.")
    parser.add_argument("--swarm", default=DEFAULT_SWARM, type=node_name("swarm name"),
                        help=f"the swarm to show, a key chunk (default {DEFAULT_SWARM})")
    parser.add_argument("--port", type=integer(1, 65535), default=DEFAULT_PORT,
                        help=f"the web page's TCP port (default {DEFAULT_PORT})")
    parser.add_argument("--host", type=ADDRESS, default=DEFAULT_HOST,
                        help=f"the address to serve on (default {DEFAULT_HOST}: this machine "
                        "only; 0.0.0.0 or :: for every interface)")
    parser.add_argument("--duration", type=positive_float(), metavar="SECONDS",
                        help="stop after this long (default: until Ctrl-C)")
    add_zenoh_arguments(parser, ("peer", "client"))
    parser.set_defaults(func=_dashboard, needs="dashboard")
