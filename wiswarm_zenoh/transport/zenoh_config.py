"""Zenoh configuration from the command line, with the flags of zenoh-python's examples
(``wiswarm_zenoh.options.add_zenoh_arguments``).

Every problem (a bad endpoint, an unknown ``--cfg`` key, an unreadable ``-c`` file, a
session that cannot open) becomes one ``UsageError`` line: the user must fix a flag.
Endpoints are checked before Zenoh sees them: it would take a bad one only at session
open, or not at all (a peer retries a connect endpoint forever, in the background).

Zenoh's shared memory is off unless asked for (``shared_memory``): with it, every
process that sends to a router or leader on the same host leaves its 16 MiB pool and
1.25 MiB metadata segment mapped there for as long as they run
(eclipse-zenoh/zenoh#2787), and polling gains some 7 % from it, on one host only
(docs/guides/swarm.md#shared-memory).
"""

from __future__ import annotations

import argparse
import ipaddress
import json
import re
import socket
from collections.abc import Sequence
from dataclasses import dataclass

import zenoh

from wiswarm_zenoh.transport import shm_sweep
from wiswarm_zenoh.transport.tls_files import check_tls
from wiswarm_zenoh.usage import UsageError

MODES = ("peer", "client", "router")
# The mode of a node given a router by -e (and nothing to listen on): a client, as Zenoh
# advises for a node attached to a router. In peer mode, a peer that reaches another
# both directly and through routers can miss its liveliness tokens (issue 40,
# bench_liveliness_answers, bench_discovery); a client's router answers for all, and
# robots' links stay through their own routers (docs/guides/swarm.md#session-modes).
ATTACHED_MODE = "client"
LOCAL_ROUTER = "tcp/127.0.0.1:7447"
# The link protocols of this zenoh-python build that a session can use (unixpipe, vsock
# and serial are not compiled in: Zenoh says "Unicast not supported" at open).
PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream")
_LABEL = re.compile(r"^(?!-)[A-Za-z0-9-]{1,63}(?<!-)$")
_RUST_SUFFIX = re.compile(r"\s+at /\S+\.rs:\d+\.?\s*$")
_JSON5_MESSAGE = re.compile(r'(?:msg: |Str\()"((?:[^"\\]|\\.)*)"')


def zenoh_message(exc: BaseException) -> str:
    """Zenoh's error text on one line, without the Rust source location."""
    text = _RUST_SUFFIX.sub("", str(exc).strip())
    found = _JSON5_MESSAGE.search(text)
    if found:
        text = found.group(1)
    return " ".join(text.split()) or type(exc).__name__


def check_host(host: str, resolve: bool = True) -> str:
    """An IP address (IPv6 in brackets too) or a host name that, with ``resolve``,
    resolves here: a typo is refused now, not as a link that never comes up."""
    bare = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    try:
        ipaddress.ip_address(bare)
        return host
    except ValueError:
        pass
    if re.fullmatch(r"[0-9.]+", host):
        raise ValueError(f"{host!r} is not an IPv4 address (four numbers of 0-255)")
    labels = host.removesuffix(".").split(".")
    if len(host) > 253 or not all(_LABEL.match(label) for label in labels):
        raise ValueError(f"{host[:60]!r} is not a host name or IP address")
    if resolve:
        try:
            socket.getaddrinfo(host, None)
        except OSError:
            raise ValueError(f"host {host!r} does not resolve") from None
    return host


def split_host_port(text: str, lowest_port: int = 1) -> tuple[str, int]:
    """``HOST:PORT`` (``[v6]:PORT`` too) with a port in ``[lowest_port, 65535]`` and a
    host that ``check_host`` takes."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not lowest_port <= int(port) <= 65535:
        raise ValueError(f"{text[:60]!r} must look like HOST:PORT, PORT in "
                         f"[{lowest_port}, 65535]")
    return check_host(host), int(port)


def split_key_value(item: str) -> tuple[str, str]:
    """``KEY:VALUE`` of ``--cfg``, both non-empty."""
    key, sep, value = item.partition(":")
    if not sep or not key or not value:
        raise ValueError(f"--cfg expects KEY:VALUE, got {item[:60]!r}")
    return key, value


def check_endpoint(endpoint: str, listen: bool = False) -> str:
    """``PROTOCOL/HOST:PORT[?metadata][#config]`` (``unixsock-stream/PATH``) with a
    protocol of PROTOCOLS and a host that resolves; port 0 (any free one) only to listen."""
    protocol, sep, rest = endpoint.partition("/")
    address = re.split(r"[?#]", rest, maxsplit=1)[0]
    if not sep or not address:
        raise ValueError(f"endpoint {endpoint[:60]!r} must look like tcp/HOST:PORT")
    if protocol not in PROTOCOLS:
        raise ValueError(f"endpoint {endpoint[:60]!r}: protocol {protocol!r} is not one of "
                         f"{', '.join(PROTOCOLS)}")
    if protocol != "unixsock-stream":
        try:
            split_host_port(address, lowest_port=0 if listen else 1)
        except ValueError as exc:
            raise ValueError(f"endpoint {endpoint[:60]!r}: {exc}") from None
    return endpoint


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
    shared_memory: bool = False

    @classmethod
    def from_args(cls, args: argparse.Namespace, default_mode: str,
                  default_connect: Sequence[str] = ()) -> SessionSpec:
        """The parsed flags; ``default_connect`` applies only when neither ``--connect``
        nor ``--config`` says where to go. A node (``default_mode`` peer) given ``-e``
        and no ``-l`` is a client of the router it names (``attached_mode``)."""
        connect = list(args.connect)
        if not connect and args.config is None:
            connect = list(default_connect)
        if default_mode == "peer" and args.connect and not args.listen:
            default_mode = ATTACHED_MODE
        return cls(
            mode=args.mode or (None if args.config else default_mode),
            connect=tuple(connect), listen=tuple(args.listen), config_file=args.config,
            cfg=tuple(args.cfg), multicast_scouting=not args.no_multicast_scouting,
            shared_memory=args.shared_memory,
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
            multicast_scouting=self.multicast_scouting, shared_memory=self.shared_memory,
        )

    def routers(self) -> list[str]:
        """Where the node looks for its router: the flags' endpoints, else its config
        file's (a map by mode taken whole)."""
        if self.connect or self.config_file is None:
            return list(self.connect)
        endpoints = json.loads(self.config().get_json("connect/endpoints"))
        if isinstance(endpoints, dict):
            return [str(e) for each in endpoints.values() for e in each]
        return [str(e) for e in endpoints]

    def waits_for_router(self) -> bool:
        """Whether ``open(wait_for_router=True)`` waits: a client (which Zenoh opens only
        once a router answers) whose config leaves ``connect/timeout_ms`` to us."""
        config = self.config()
        mode: str = config.get_json("mode")
        timeout: str = config.get_json("connect/timeout_ms")
        return mode == '"client"' and timeout == "null"

    def open(self, wait_for_router: bool = False) -> zenoh.Session:
        """Open a session; a failure (endpoint in use, router unreachable) is a UsageError.
        ``wait_for_router`` (see ``waits_for_router``): a client waits at open for its
        router, trying again as ``RECONNECT`` says, instead of failing. With shared memory
        on, what this process leaves in /dev/shm is swept once it ends (``shm_sweep``)."""
        config = self.config()
        if wait_for_router and self.waits_for_router():
            _insert(config, "connect/timeout_ms", "{client: -1}", "waiting for the router")
        if config.get_json(SHARED_MEMORY) == "true":
            shm_sweep.watch()
        try:
            return zenoh.open(config)
        except zenoh.ZError as exc:
            message = zenoh_message(exc)
            if message.startswith("Unable to connect to any of"):  # a client, no router
                message = (f"no router answered at {', '.join(self.routers())} (a client "
                           "opens only once its router answers): is one listening there "
                           "(wiswarm router -l ...)?")
            raise UsageError(f"cannot open the Zenoh session: {message}") from None


def _insert(config: zenoh.Config, key: str, value: str, origin: str) -> None:
    try:
        config.insert_json5(key, value)
    except zenoh.ZError as exc:
        raise UsageError(f"{origin}: {zenoh_message(exc)}") from None


# How often a node tries its router again once the link is gone: from 100 ms, doubling
# to at most 500 ms (Zenoh's own default: 1 s to 4 s), so a restarted router is rejoined
# within about half a second of listening again. A config file's own setting wins.
RETRY = {"period_init_ms": 100, "period_max_ms": 500, "period_increase_factor": 2}
RECONNECT = json.dumps(RETRY)
SHARED_MEMORY = "transport/shared_memory/enabled"


def build_config(
    *,
    mode: str | None,
    connect: Sequence[str] = (),
    listen: Sequence[str] = (),
    config_file: str | None = None,
    cfg: Sequence[str] = (),
    multicast_scouting: bool = True,
    shared_memory: bool = False,
) -> zenoh.Config:
    """A checked ``zenoh.Config``; flags override the file, ``--cfg`` overrides both.
    Shared memory is as ``shared_memory`` says whatever the file says (Zenoh's default,
    on, cannot be told from a file's own ``true``); ``--cfg`` may still set it."""
    if config_file is None:
        config = zenoh.Config()
    else:
        try:
            config = zenoh.Config.from_file(config_file)
        except zenoh.ZError as exc:
            raise UsageError(f"config file {config_file}: {zenoh_message(exc)}") from None
    if config.get_json("connect/retry") == "null":  # the file leaves it to us
        _insert(config, "connect/retry", RECONNECT, "reconnection defaults")
    if mode is not None:
        if mode not in MODES:
            raise UsageError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        _insert(config, "mode", json.dumps(mode), "--mode")
    try:
        for endpoint in connect:
            check_endpoint(endpoint)
        for endpoint in listen:
            check_endpoint(endpoint, listen=True)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if connect:
        _insert(config, "connect/endpoints", json.dumps(list(connect)), "--connect")
    if listen:
        _insert(config, "listen/endpoints", json.dumps(list(listen)), "--listen")
    if not multicast_scouting:
        _insert(config, "scouting/multicast/enabled", "false", "--no-multicast-scouting")
    _insert(config, SHARED_MEMORY, json.dumps(shared_memory), "--shared-memory")
    for item in cfg:
        try:
            key, value = split_key_value(item)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
        _insert(config, key, value, f"--cfg {key}")
    _open_at_once_with_nobody_to_scout(config)
    check_tls(config)  # a bad certificate named here, not as a TLS error at open
    return config


def _open_at_once_with_nobody_to_scout(config: zenoh.Config) -> None:
    """A router that scouts nobody by multicast and connects to nobody has nothing to
    wait for at open, yet Zenoh waits its scouting delay (500 ms) there: no delay then,
    unless the config sets one."""
    endpoints = json.loads(config.get_json("connect/endpoints"))
    if (config.get_json("mode") == '"router"'
            and config.get_json("scouting/multicast/enabled") == "false"
            and config.get_json("scouting/delay") == "null"
            and not any(endpoints.values() if isinstance(endpoints, dict) else endpoints)):
        _insert(config, "scouting/delay", "0", "scouting delay")


def free_tcp_port() -> int:
    """A TCP port on 127.0.0.1 free right now (for loopback routers and tests)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port
