"""Fixtures: a free port, a loopback router, sessions closed after each test."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

from .helpers import Recorder, Sessions


@pytest.fixture
def sessions() -> Iterator[Sessions]:
    opened = Sessions()
    yield opened
    opened.close_all()


@pytest.fixture
def port() -> int:
    return free_tcp_port()


@pytest.fixture
def router(sessions: Sessions, port: int) -> zenoh.Session:
    return sessions.router(port)


@pytest.fixture
def recorder() -> Recorder:
    return Recorder()
