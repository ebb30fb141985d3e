"""Zenoh configuration from the command line, with the flags of zenoh-python's examples.

Every problem (a bad endpoint, an unknown ``--cfg`` key, an unreadable ``-c`` file, a
session that cannot open) becomes one ``UsageError`` line: the user must fix a flag.
"""

from __future__ import annotations

import argparse
import json
import re
import socket
from collections.abc import Sequence
from dataclasses import dataclass

import zenoh

from wiswarm_zenoh.cli.usage import UsageError

MODES = ("peer", "client", "router")
LOCAL_ROUTER = "tcp/127.0.0.1:7447"
_RUST_SUFFIX = re.compile(r"\s+at /\S+\.rs:\d+\.?\s*$")
_JSON5_MESSAGE = re.compile(r'(?:msg: |Str\()"((?:[^"\\]|\\.)*)"')


def zenoh_message(exc: BaseException) -> str:
    """Zenoh's error text on one line, without the Rust source location."""
    text = _RUST_SUFFIX.sub("", str(exc).strip())
    found = _JSON5_MESSAGE.search(text)
    if found:
        text = found.group(1)
    return " ".join(text.split()) or type(exc).__name__


def add_zenoh_arguments(parser: argparse.ArgumentParser, modes: Sequence[str]) -> None:
    """The session flags: -m/-e/-l/-c, --cfg KEY:VALUE, --no-multicast-scouting."""
    group = parser.add_argument_group("zenoh session")
    group.add_argument("-m", "--mode", choices=list(modes), help="the Zenoh session mode")
    group.add_argument("-e", "--connect", metavar="ENDPOINT", action="append", default=[],
                       help="endpoint to connect to, e.g. tcp/HOST:7447 (repeatable)")
    group.add_argument("-l", "--listen", metavar="ENDPOINT", action="append", default=[],
                       help="endpoint to listen on (repeatable)")
    group.add_argument("-c", "--config", metavar="FILE", help="a Zenoh JSON5 configuration file")
    group.add_argument("--cfg", metavar="KEY:VALUE", action="append", default=[],
                       help="set one configuration value (VALUE is JSON5), "
                            "e.g. --cfg 'transport/unicast/max_links:2'")
    group.add_argument("--no-multicast-scouting", action="store_true",
                       help="do not discover peers and routers by multicast")


@dataclass(frozen=True)
class SessionSpec:
    """How to open a session, as plain values: it crosses ``spawn`` to child processes
    (a ``zenoh.Config`` cannot be pickled). ``None`` mode keeps the file's or Zenoh's."""

    mode: str | None = None
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    config_file: str | None = None
    cfg: tuple[str, ...] = ()
    multicast_scouting: bool = True

    @classmethod
    def from_args(cls, args: argparse.Namespace, default_mode: str,
                  default_connect: Sequence[str] = ()) -> SessionSpec:
        """The parsed flags; ``default_connect`` applies only when neither ``--connect``
        nor ``--config`` says where to go."""
        connect = list(args.connect)
        if not connect and args.config is None:
            connect = list(default_connect)
        return cls(
            mode=args.mode or (None if args.config else default_mode),
            connect=tuple(connect), listen=tuple(args.listen), config_file=args.config,
            cfg=tuple(args.cfg), multicast_scouting=not args.no_multicast_scouting,
        )

    @classmethod
    def loopback(cls, mode: str, listen_port: int | None = None,
                 connect_ports: Sequence[int] = ()) -> SessionSpec:
        """127.0.0.1 only, multicast scouting off: demos, tests, benchmarks.

        A peer always gets a listener (an ephemeral port if none is given): a peer
        without one is not reachable through gossip and misses replies routed to it.
        """
        listen = [f"tcp/127.0.0.1:{listen_port}"] if listen_port is not None else []
        if not listen and mode == "peer":
            listen = ["tcp/127.0.0.1:0"]
        return cls(
            mode=mode, connect=tuple(f"tcp/127.0.0.1:{port}" for port in connect_ports),
            listen=tuple(listen), multicast_scouting=False,
        )

    def config(self) -> zenoh.Config:
        """A checked ``zenoh.Config``; flags override the file, ``--cfg`` overrides both."""
        return build_config(
            mode=self.mode, connect=self.connect, listen=self.listen,
            config_file=self.config_file, cfg=self.cfg,
            multicast_scouting=self.multicast_scouting,
        )

    def open(self) -> zenoh.Session:
        """Open a session; a failure (endpoint in use, router unreachable) is a UsageError."""
        config = self.config()
        try:
            return zenoh.open(config)
        except zenoh.ZError as exc:
            raise UsageError(f"cannot open the Zenoh session: {zenoh_message(exc)}") from None


def _insert(config: zenoh.Config, key: str, value: str, origin: str) -> None:
    try:
        config.insert_json5(key, value)
    except zenoh.ZError as exc:
        raise UsageError(f"{origin}: {zenoh_message(exc)}") from None


def build_config(
    *,
    mode: str | None,
    connect: Sequence[str] = (),
    listen: Sequence[str] = (),
    config_file: str | None = None,
    cfg: Sequence[str] = (),
    multicast_scouting: bool = True,
) -> zenoh.Config:
    """A checked ``zenoh.Config``; flags override the file, ``--cfg`` overrides both."""
    if config_file is None:
        config = zenoh.Config()
    else:
        try:
            config = zenoh.Config.from_file(config_file)
        except zenoh.ZError as exc:
            raise UsageError(f"config file {config_file}: {zenoh_message(exc)}") from None
    if mode is not None:
        if mode not in MODES:
            raise UsageError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        _insert(config, "mode", json.dumps(mode), "--mode")
    for endpoint in (*connect, *listen):
        if "/" not in endpoint:
            raise UsageError(f"endpoint {endpoint!r} must look like tcp/HOST:PORT")
    if connect:
        _insert(config, "connect/endpoints", json.dumps(list(connect)), "--connect")
    if listen:
        _insert(config, "listen/endpoints", json.dumps(list(listen)), "--listen")
    if not multicast_scouting:
        _insert(config, "scouting/multicast/enabled", "false", "--no-multicast-scouting")
    for item in cfg:
        key, sep, value = item.partition(":")
        if not sep or not key or not value:
            raise UsageError(f"--cfg expects KEY:VALUE, got {item!r}")
        _insert(config, key, value, f"--cfg {key}")
    return config


def free_tcp_port() -> int:
    """A TCP port on 127.0.0.1 free right now (for loopback routers and tests)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port
