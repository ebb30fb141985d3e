"""What the commands that only watch a swarm share (``wiswarm dashboard``, ``record``,
``foxglove``): like the other nodes they connect to a router on this machine
(tcp/127.0.0.1:7447) as a peer unless -e or -c says otherwise; they only subscribe, so
they never slow the swarm. Those that serve something take --port and --host."""

from __future__ import annotations

import argparse
import ipaddress

from wiswarm_zenoh.cli.nodes import DEFAULT_SWARM
from wiswarm_zenoh.options import ArgType, add_zenoh_arguments, integer, node_name, positive_float
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


def add_watch_arguments(parser: argparse.ArgumentParser, swarm: str) -> None:
    """--swarm (``swarm`` says what of it), --duration and the Zenoh flags."""
    parser.add_argument("--swarm", default=DEFAULT_SWARM, type=node_name("swarm name"),
                        help=f"{swarm}, a key chunk (default {DEFAULT_SWARM})")
    parser.add_argument("--duration", type=positive_float(), metavar="SECONDS",
                        help="stop after this long (default: until Ctrl-C)")
    add_zenoh_arguments(parser, ("peer", "client"))


def add_serve_arguments(parser: argparse.ArgumentParser, what: str, port: int, host: str,
                        any_port: bool) -> None:
    """--port (of ``what``; with ``any_port``, 0 takes any free one) and --host."""
    parser.add_argument("--port", type=integer(0 if any_port else 1, 65535), default=port,
                        help=f"{what}'s TCP port (default {port}"
                        + ("; 0: any free one)" if any_port else ")"))
    parser.add_argument("--host", type=ADDRESS, default=host,
                        help=f"the address to serve on (default {host}: this machine "
                        "only; 0.0.0.0 or :: for every interface)")


def watch_spec(args: argparse.Namespace) -> SessionSpec:
    """The session ``add_watch_arguments``' flags describe, every flag checked before
    anything starts."""
    spec = SessionSpec.from_args(args, "peer", (LOCAL_ROUTER,))
    spec.config()
    return spec
