"""Fixtures: a secured swarm in tmp_path, its router on a free loopback port."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

from .helpers import Sessions, make_swarm


@pytest.fixture
def port() -> int:
    return free_tcp_port()


@pytest.fixture
def swarm(tmp_path: Path, port: int) -> Path:
    return make_swarm(tmp_path / "swarm", port)


@pytest.fixture
def sessions(swarm: Path) -> Iterator[Sessions]:
    opened = Sessions(swarm)
    yield opened
    opened.close_all()


@pytest.fixture
def router(sessions: Sessions) -> zenoh.Session:
    """The secured router: a Python session opened from router.json5 (mode router)."""
    return sessions.open("router")
