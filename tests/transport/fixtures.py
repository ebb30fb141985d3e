"""The loopback fixtures the transport and ROS 2 tests share: a free port, a router on
it, sessions closed after each test, a recorder of a leader's callbacks. Each folder's
conftest takes in the ones it uses by name."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from tests.transport.helpers import Recorder, Sessions
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port


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
