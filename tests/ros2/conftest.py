"""The transport tests' loopback fixtures, and a third-party ROS 2 client
(``client.run_client``) in a ``spawn`` child, talked to over a pipe; message definitions
laid out for it in the test's directory."""

from __future__ import annotations

import multiprocessing
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.transport.fixtures import port, recorder, sessions  # noqa: F401  (fixtures)

from .client import run_client
from .definitions import write_definitions

WAIT_S = 20.0  # the client's discovery takes a few seconds on a busy machine


class Client:
    """The child's messages, by kind, as they come; commands to it."""

    def __init__(self, router_port: int, domain: int, definitions: Path, expected: list[str],
                 subscribe: list[tuple[str, str, int]]) -> None:
        context = multiprocessing.get_context("spawn")
        self._pipe, theirs = context.Pipe()
        self._process = context.Process(target=run_client, args=(
            router_port, domain, definitions, expected, subscribe, theirs), daemon=True)
        self._process.start()
        self.inbox: list[tuple[Any, ...]] = []

    def next(self, *head: str) -> tuple[Any, ...]:
        """The next message that starts with ``head`` (others are kept for later)."""
        for i, message in enumerate(self.inbox):
            if message[:len(head)] == head:
                return self.inbox.pop(i)
        while self._pipe.poll(WAIT_S):
            message = tuple(self._pipe.recv())
            if message[:len(head)] == head:
                return message
            self.inbox.append(message)
        raise AssertionError(f"timed out waiting for the client's {head}")

    def publish(self, topic: str, kind: str,
                poses: list[tuple[float, float, float, float]]) -> None:
        self._pipe.send(("publish", topic, kind, poses))
        self.next("sent")

    def close(self) -> None:
        self._pipe.send(("stop",))
        self._process.join(WAIT_S)
        if self._process.is_alive():
            self._process.kill()
            self._process.join()


@pytest.fixture
def open_client(tmp_path: Path) -> Iterator[Any]:
    clients: list[Client] = []

    def start(router_port: int, domain: int, expected: list[str],
              subscribe: list[tuple[str, str, int]]) -> Client:
        client = Client(router_port, domain, write_definitions(tmp_path / "msg"), expected,
                        subscribe)
        clients.append(client)
        return client

    yield start
    for client in clients:
        client.close()
