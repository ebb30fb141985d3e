"""Fan-out of the state's messages to the browsers connected over WebSockets.

Any thread may ``publish``; the messages are numbered, gathered and sent by the event
loop as one JSON list per wake-up (a burst of stats costs one frame per browser, and a
delivery batch goes out at once). Each browser has its own bounded queue and sender: a
slow or stalled one is dropped (its page reconnects and starts from a snapshot), never
waited for.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import threading
from dataclasses import dataclass, field
from typing import Any

from wiswarm_zenoh.dashboard.state import Message

log = logging.getLogger(__name__)

QUEUE_FRAMES = 256  # frames waiting for one browser before it is dropped


def _finite(value: Any) -> Any:
    """``value`` with every non-finite float as None (the browser's JSON has no inf)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def to_text(messages: list[Message]) -> str:
    """One WebSocket frame: a JSON list of messages."""
    try:
        return json.dumps(messages, separators=(",", ":"), allow_nan=False)
    except ValueError:  # a non-finite number somewhere: rare, so cleaned only then
        return json.dumps(_finite(messages), separators=(",", ":"), allow_nan=False)


@dataclass(eq=False)
class Client:
    """One browser: frames to send, from the message after ``since`` on."""

    since: int
    queue: asyncio.Queue[str | None] = field(
        default_factory=lambda: asyncio.Queue(QUEUE_FRAMES))


class Hub:
    """The browsers of one dashboard; created and used on its event loop, except
    ``publish`` (any thread)."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop
        self._lock = threading.Lock()
        self._seq = 0
        self._pending: list[tuple[int, Message]] = []
        self._clients: set[Client] = set()
        self.dropped = 0  # browsers dropped for falling behind

    def publish(self, message: Message) -> int:
        """Number ``message`` and have the loop send it; returns its number (a sample
        still on its way as the dashboard closes is dropped)."""
        with self._lock:
            self._seq += 1
            self._pending.append((self._seq, message))
            if len(self._pending) == 1:
                with contextlib.suppress(RuntimeError):  # the loop is closed: never sent
                    self._loop.call_soon_threadsafe(self._flush)
            return self._seq

    def join(self, first: Message, since: int) -> Client:
        """A new browser: ``first`` (its snapshot, which includes every message up to
        ``since``), then the messages after it."""
        client = Client(since)
        client.queue.put_nowait(to_text([first]))
        self._clients.add(client)
        return client

    def leave(self, client: Client) -> None:
        self._clients.discard(client)

    def _flush(self) -> None:
        with self._lock:
            pending, self._pending = self._pending, []
        if not pending:
            return
        texts: dict[int, str] = {}  # by the number of messages skipped: usually one text
        for client in list(self._clients):
            skip = next((i for i, (seq, _) in enumerate(pending) if seq > client.since),
                        len(pending))
            if skip == len(pending):
                continue
            if skip not in texts:
                texts[skip] = to_text([message for _, message in pending[skip:]])
            client.since = pending[-1][0]
            try:
                client.queue.put_nowait(texts[skip])
            except asyncio.QueueFull:
                self._drop(client)

    def _drop(self, client: Client) -> None:
        """A browser that stopped reading: its sender ends (the page reconnects)."""
        log.warning("a browser fell %d frames behind: dropping it", QUEUE_FRAMES)
        self.dropped += 1
        self._end(client)

    def close_all(self) -> None:
        """The server is going: every sender ends, closing its WebSocket."""
        for client in list(self._clients):
            self._end(client)

    def _end(self, client: Client) -> None:
        self._clients.discard(client)
        while not client.queue.empty():
            client.queue.get_nowait()
        client.queue.put_nowait(None)
