"""``wiswarm dashboard``: a live web page of a swarm, from its key expressions only
(a command that watches: ``watching``)."""

from __future__ import annotations

import argparse
import socket
import threading
from typing import Any

from wiswarm_zenoh.cli.watching import add_serve_arguments, add_watch_arguments, watch_spec
from wiswarm_zenoh.dashboard import DEFAULT_HOST, DEFAULT_PORT, Dashboard
from wiswarm_zenoh.options import UsageError
from wiswarm_zenoh.programs.runners import wait_until_stopped
from wiswarm_zenoh.transport.zenoh_config import SessionSpec


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
    dashboard = serve(watch_spec(args), args.swarm, args.port, args.host)
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
    add_serve_arguments(parser, "the web page", DEFAULT_PORT, DEFAULT_HOST, any_port=False)
    add_watch_arguments(parser, "the swarm to show")
    parser.set_defaults(func=_dashboard, needs="dashboard")
