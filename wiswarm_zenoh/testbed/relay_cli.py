"""The relay's command line: ``python -m wiswarm_zenoh.testbed.relay --listen HOST:PORT
--target HOST:PORT --delay 20ms``, a ``DelayRelay`` as a process of its own (inside a
namespace, between two routers)."""

from __future__ import annotations

import argparse
import functools
import logging
import signal
import socket
import sys
import threading
from collections.abc import Callable, Sequence

from wiswarm_zenoh.testbed.relay import Address, DelayRelay, address_text
from wiswarm_zenoh.units import parse_seconds
from wiswarm_zenoh.usage import OneLineParser

PROG = "python -m wiswarm_zenoh.testbed.relay"
DESCRIPTION = ("A TCP relay holding every byte for a fixed delay: the one-way delay of a "
               "wide-area link between Zenoh routers.")


def parse_address(text: str, lowest_port: int = 1) -> Address:
    """``HOST:PORT`` (``[V6]:PORT`` too) -> (host, port); ValueError if it is malformed
    or the host does not resolve."""
    host, _, port = text.rpartition(":")
    host = host[1:-1] if host[:1] == "[" and host[-1:] == "]" else host
    if not (host and port.isdigit() and lowest_port <= int(port) <= 65535) or "[" in host:
        raise ValueError(f"{text[:60]!r} must be HOST:PORT, PORT in [{lowest_port}, 65535]")
    try:
        socket.getaddrinfo(host, int(port), type=socket.SOCK_STREAM)
    except (OSError, UnicodeError) as exc:
        raise ValueError(f"host {host[:60]!r} does not resolve: {exc}") from None
    return host, int(port)


def _arg(parse: Callable[[str], object]) -> Callable[[str], object]:
    """An argparse type whose ValueError message is the one line shown."""
    def convert(text: str) -> object:
        try:
            return parse(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return convert


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog=PROG, description=DESCRIPTION)
    add = parser.add_argument
    add("--listen", required=True, metavar="HOST:PORT", help="accept here (port 0: any)",
        type=_arg(functools.partial(parse_address, lowest_port=0)))
    add("--target", required=True, metavar="HOST:PORT", type=_arg(parse_address),
        help="relay to here")
    add("--delay", required=True, type=_arg(parse_seconds), help="one way: 20ms, 0.02 (s)")
    add("--delay-back", type=_arg(parse_seconds), help="target -> listen side (default: --delay)")
    add("-v", "--verbose", action="count", default=0, help="log connections (-vv: more)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Relay until SIGINT/SIGTERM. The first line on stdout names the address bound; a
    bad flag, or an address that cannot be bound, is one line on stderr, exit 2."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 2
    logging.basicConfig(level=logging.WARNING - 10 * min(args.verbose, 2))
    relay = DelayRelay(args.listen, args.target, args.delay, delay_back=args.delay_back)
    try:
        relay.start()
    except OSError as exc:
        print(f"{PROG}: error: cannot listen on {address_text(args.listen)}: "
              f"{exc.strerror or exc}", file=sys.stderr)
        return 2
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    print(f"listening on {address_text((args.listen[0], relay.port))}, relaying to "
          f"{address_text(args.target)} {relay.delay * 1e3:g} ms late there, "
          f"{relay.delay_back * 1e3:g} ms back", flush=True)
    stop.wait()  # SIGINT too sets it: no KeyboardInterrupt comes
    relay.stop()
    c = relay.counters()
    print(f"relayed {c.to_target_bytes} bytes to the target and {c.from_target_bytes} back "
          f"over {c.connections} connections ({c.unreachable} could not reach it); latest "
          f"write {c.max_lateness_s * 1e3:.3f} ms after due", file=sys.stderr)
    return 0

