"""Shared fixtures of the tracking tests that use real Zenoh sessions on loopback."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import pytest

from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

WAIT_S = 10.0


@pytest.fixture
def node_spec() -> Iterator[SessionSpec]:
    """A Zenoh router in this process (its own session); nodes connect to it as peers,
    on 127.0.0.1 only, multicast scouting off."""
    port = free_tcp_port()
    with SessionSpec.loopback("router", port).open():
        yield SessionSpec.loopback("peer", connect_ports=[port])


def wait_until(condition: Callable[[], bool], timeout: float = WAIT_S) -> bool:
    """For states no event signals (a counter reached, a position reached): check every
    few milliseconds until true or the deadline."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.005)
    return condition()


@pytest.fixture
def wait() -> Callable[..., bool]:
    return wait_until
