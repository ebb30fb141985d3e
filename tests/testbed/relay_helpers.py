"""What the relay tests share: a relayed and a direct connection, reading helpers."""

from __future__ import annotations

import hashlib
import socket
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import ExitStack, contextmanager
from typing import TypeVar

import pytest

from wiswarm_zenoh.testbed.relay import (
    DEFAULT_MAX_HELD,
    DEFAULT_MAX_LAG,
    DelayRelay,
)

T = TypeVar("T")
WAIT = 10.0
LOCAL = "127.0.0.1"
DELAY = 0.020
SLACK = 0.002  # the bound on what the relay adds beyond its delay


@pytest.fixture
def no_relay_thread_left() -> Iterator[None]:
    yield
    left = [t.name for t in threading.enumerate() if t.name.startswith("delay-relay")]
    assert not left, f"relay threads still running: {left}"


@contextmanager
def relayed(delay: float, max_held: int = DEFAULT_MAX_HELD, max_lag: float = DEFAULT_MAX_LAG,
             rcvbuf: int | None = None) -> Iterator[tuple[DelayRelay, socket.socket,
                                                          socket.socket]]:
    """A relay to a fresh server, one connection through it: (relay, client, server end);
    ``rcvbuf`` fixes the server end's receive buffer (no autotuning)."""
    with ExitStack() as stack:
        server = stack.enter_context(socket.socket())
        if rcvbuf is not None:
            server.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
        server.bind((LOCAL, 0))
        server.listen()
        server.settimeout(WAIT)
        relay = stack.enter_context(DelayRelay((LOCAL, 0), server.getsockname(), delay,
                                               max_held=max_held, max_lag=max_lag))
        client = stack.enter_context(socket.create_connection((LOCAL, relay.port), WAIT))
        end, _ = server.accept()
        stack.enter_context(end)
        for sock in (client, end):
            sock.settimeout(WAIT)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        yield relay, client, end


@contextmanager
def direct() -> Iterator[tuple[socket.socket, socket.socket]]:
    """A connected pair (client, server end) without a relay: the control."""
    with ExitStack() as stack:
        server = stack.enter_context(socket.create_server((LOCAL, 0)))
        client = stack.enter_context(socket.create_connection(server.getsockname(), WAIT))
        end = stack.enter_context(server.accept()[0])
        for sock in (client, end):
            sock.settimeout(WAIT)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        yield client, end


def recv_exact(sock: socket.socket, size: int) -> bytes:
    buf = bytearray(size)
    view, got = memoryview(buf), 0
    while got < size:
        n = sock.recv_into(view[got:])
        if n == 0:
            raise EOFError(f"EOF after {got} of {size} bytes")
        got += n
    return bytes(buf)


def drain(sock: socket.socket) -> tuple[int, str]:
    """Read to EOF: (bytes, sha256)."""
    digest, total = hashlib.sha256(), 0
    while data := sock.recv(1 << 20):
        digest.update(data)
        total += len(data)
    return total, digest.hexdigest()


def send_and_close(sock: socket.socket, payload: bytes) -> None:
    sock.sendall(payload)
    sock.shutdown(socket.SHUT_WR)


def run(*tasks: Callable[[], T]) -> list[T]:
    with ThreadPoolExecutor(len(tasks)) as pool:
        futures: list[Future[T]] = [pool.submit(task) for task in tasks]
        return [future.result(WAIT) for future in futures]
