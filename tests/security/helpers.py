"""What the security tests share: a swarm directory, sessions opened from its configs,
inboxes to wait on, a barrier through the router, and ``wiswarm`` as a process."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import zenoh

from wiswarm_zenoh.security.acl import Roster
from wiswarm_zenoh.security.deploy import Plan, init
from wiswarm_zenoh.testbed.faults import Output
from wiswarm_zenoh.transport import SessionSpec, SwarmKeys
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

WAIT = 15.0  # seconds: generous, since the machine may be busy; met in well under 1 s
SWARM = "s"
KEYS = SwarmKeys(SWARM)
Permission = tuple[str, str, str]  # (message, flow, key expression)
# The CLI with only the modules used here: a quicker start than all of them.
ENTRY = ("import sys; from wiswarm_zenoh.cli import main as m, nodes, security; "
         "sys.exit(m.main(registrars=(nodes.register, security.register)))")


def wiswarm(*argv: str) -> list[str]:
    """``wiswarm ARGV`` as a command line."""
    return [sys.executable, "-c", ENTRY, *argv]


def router_process(config: Path) -> Output:
    """``wiswarm -v router -c CONFIG``, its output kept (our INFO lines, Zenoh's at
    warn): started, not yet waited for."""
    return Output(config.stem, subprocess.Popen(
        wiswarm("-v", "router", "-c", str(config)), stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "RUST_LOG": "warn", "PYTHONUNBUFFERED": "1"}))


def stop(process: Output) -> None:
    process.popen.terminate()
    process.popen.wait(WAIT)


def free_ports(count: int) -> int:
    """The first of ``count`` consecutive TCP ports on 127.0.0.1 free right now (a
    place's routers listen on consecutive ports)."""
    while True:
        first = free_tcp_port()
        try:
            for port in range(first + 1, first + count):
                with socket.socket() as sock:
                    sock.bind(("127.0.0.1", port))
        except OSError:
            continue
        return first


def follower_permissions(keys: SwarmKeys, follower: str) -> set[Permission]:
    """What a follower's certificate may do: serve and hold tokens for itself and for
    its streams (``<follower>~<stream>``), and hear the control."""
    streams = f"{keys.prefix}/{follower}~$*"
    return {
        *((m, f, k) for k in (keys.update(follower), f"{streams}/update") for m, f in (
            ("declare_queryable", "ingress"), ("reply", "ingress"), ("query", "egress"))),
        *(("liveliness_token", "ingress", k) for k in (
            keys.member(follower), f"{keys.source(follower)}/**",
            f"{keys.prefix}/members/{follower}~$*", f"{streams}/source/**")),
        ("declare_subscriber", "ingress", keys.control), ("put", "egress", keys.control)}


def make_swarm(directory: Path, port: int, followers: tuple[str, ...] = ("f1", "f2"),
               observers: tuple[str, ...] = ("o1", "o2")) -> Path:
    """A swarm directory whose router listens on 127.0.0.1:``port`` only."""
    endpoint = (f"tls/127.0.0.1:{port}",)
    init(directory, Plan(Roster(SWARM, "leader", followers, observers), listen=endpoint,
                         connect=endpoint, days=1))
    return directory


def init_sites(out: Path, port: int, *more: str) -> Path:
    """``wiswarm security init`` of a cloud (observer ground) and sites s1 (uav1, uav2)
    and s2 (uav1) in ``out``, its first router on ``port``, ``more`` flags besides."""
    from wiswarm_zenoh.cli.main import main

    assert main(["security", "init", "--out", str(out), "--swarm", "cloud", "--port",
                 str(port), "--site", "s1:uav1,uav2", "--site", "s2:uav1", "--observers",
                 "ground", *more]) == 0
    return out.resolve()


class Sessions:
    """Opens sessions from a swarm's configs and closes them all at the end of the test."""

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.opened: list[zenoh.Session] = []

    def open(self, name: str, site: str | None = None, *,
             connect: tuple[str, ...] = (), listen: tuple[str, ...] = ()) -> zenoh.Session:
        """``name``'s session (of ``site``, in a deployment of sites), endpoints as given
        on the command line over its config's."""
        place = self.directory if site is None else self.directory / site
        session = SessionSpec(config_file=str(place / f"{name}.json5"), connect=connect,
                              listen=listen).open()
        self.opened.append(session)
        return session

    def close_all(self) -> None:
        for session in reversed(self.opened):
            if not session.is_closed():
                session.close()


class Inbox:
    """A subscriber keeping every payload it gets, waitable."""

    def __init__(self, session: zenoh.Session, key_expr: str) -> None:
        self.payloads: list[bytes] = []
        self.cond = threading.Condition()
        self._subscriber = session.declare_subscriber(key_expr, self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        with self.cond:
            self.payloads.append(sample.payload.to_bytes())
            self.cond.notify_all()

    def received(self, payload: bytes, timeout: float) -> bool:
        with self.cond:
            return self.cond.wait_for(lambda: payload in self.payloads, timeout)

    def wait_for(self, payload: bytes) -> list[bytes]:
        """Everything received up to ``payload`` (which must come)."""
        with self.cond:
            assert self.cond.wait_for(lambda: payload in self.payloads, WAIT), \
                f"timed out waiting for {payload!r}"
            return self.payloads[:self.payloads.index(payload)]


def answer(session: zenoh.Session, key: str, payload: bytes) -> zenoh.Queryable[None]:
    """A queryable that answers ``payload`` on ``key``."""
    def on_query(query: zenoh.Query) -> None:
        with query:
            query.reply(key, payload)

    return session.declare_queryable(key, on_query)


def replies(session: zenoh.Session, key: str, timeout: float = 2.0) -> list[bytes]:
    """The payloads of every reply to one ``get`` (all queryables, none merged)."""
    return [reply.ok.payload.to_bytes() for reply in session.get(
        key, target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE,
        timeout=timeout) if reply.ok is not None]


def until(what: str, check: Callable[[], bool]) -> None:
    """Retry ``check`` (each try is itself a wait, e.g. a get) until it holds, for WAIT
    seconds: a get that no queryable matches yet (its declaration still on its way to
    the router, on a busy machine) ends at once, so the tries are timed, not counted."""
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        if check():
            return
    raise AssertionError(f"never happened: {what}")


def flushed(leader: zenoh.Session, follower: str) -> None:
    """Once this returns, the router has handled everything ``follower``'s session sent
    before: the leader got its reply to a poll (the reply followed them on the same
    link, at the same priority), so a rogue message of the follower was taken or
    refused by then. The follower must answer on its key with ``answer(..., b"ack")``."""
    until(f"{follower} answers", lambda: b"ack" in replies(leader, KEYS.update(follower), 1.0))


def said_in_one_line(code: int, err: str, message: str) -> None:
    """A command refused its input: exit 2 and one line on stderr, saying ``message``."""
    assert code == 2 and err.count("\n") == 1 and message in err, err
