"""Fixtures of the dashboard's tests: a loopback router, sessions closed after each test
(shared memory off, as on a network), a dashboard, and headless Chromium when there is
one."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from tests.transport.helpers import Sessions
from wiswarm_zenoh.dashboard import Dashboard
from wiswarm_zenoh.transport import SessionSpec, free_tcp_port

from .browser import CHROMIUM, Browser

NO_SHM = ("transport/shared_memory/enabled:false",)


def loopback(mode: str, port: int) -> SessionSpec:
    """A router listening on ``port``, or a peer of it: 127.0.0.1 only, no multicast
    scouting, no shared memory."""
    spec = (SessionSpec.loopback("router", port) if mode == "router"
            else SessionSpec.loopback(mode, connect_ports=[port]))
    return SessionSpec(mode=spec.mode, connect=spec.connect, listen=spec.listen,
                       multicast_scouting=False, cfg=NO_SHM)


@pytest.fixture
def port() -> int:
    return free_tcp_port()


@pytest.fixture
def sessions(port: int) -> Iterator[Sessions]:
    """Sessions of a router on ``port`` (opened first): ``sessions.open(loopback(...))``."""
    opened = Sessions()
    opened.open(loopback("router", port))
    yield opened
    opened.close_all()


@pytest.fixture
def node(sessions: Sessions, port: int) -> zenoh.Session:
    """One more peer of the router (call ``sessions.open`` for others)."""
    return sessions.open(loopback("peer", port))


@pytest.fixture
def dashboard(sessions: Sessions, port: int) -> Iterator[Dashboard]:
    """A dashboard of swarm "d" on a free port, on a session of its own."""
    with Dashboard(sessions.open(loopback("peer", port)), "d", port=0) as running:
        yield running


@pytest.fixture
def browser() -> Iterator[Browser]:
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (Debian: apt-get install -y chromium): "
                    "the browser tests need a real headless browser")
    opened = Browser()
    yield opened
    opened.close()
