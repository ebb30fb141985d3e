"""Where a stream of items goes, as in zenoh-python's ``handlers``: a plain callable
(run on the producing thread: keep it short), a ``FifoChannel`` (every item in order;
a full one makes the producer wait) or a ``RingChannel`` (the latest items only; the
producer never waits). A channel is read with ``recv``, ``try_recv`` or a ``for`` loop,
which ends when the owner closes it (a ``Receiver``'s methods do the same on the
owner).
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Iterator
from typing import Generic, TypeAlias, TypeVar

T = TypeVar("T")


class Channel(Generic[T]):
    """A bounded, thread-safe queue of items between a producer and one reader."""

    def __init__(self, capacity: int, *, wait_when_full: bool) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be at least 1, got {capacity}")
        self.capacity = capacity
        self._wait_when_full = wait_when_full
        self._items: deque[T] = deque()
        self._cond = threading.Condition()
        self._closed = False

    def put(self, item: T) -> None:
        """Called by the producer: keep ``item`` (after the reader made room, or in place
        of the oldest); dropped once the channel is closed."""
        with self._cond:
            if self._wait_when_full:
                self._cond.wait_for(lambda: len(self._items) < self.capacity or self._closed)
            if self._closed:
                return
            if len(self._items) == self.capacity:
                self._items.popleft()
            self._items.append(item)
            self._cond.notify_all()

    def recv(self, timeout: float | None = None) -> T | None:
        """The oldest item kept, waiting for one up to ``timeout`` seconds (None: as long
        as the channel is open); None if none came or the channel is closed and empty."""
        with self._cond:
            self._cond.wait_for(lambda: self._items or self._closed, timeout)
            return self._take()

    def try_recv(self) -> T | None:
        """The oldest item kept, or None at once if there is none."""
        with self._cond:
            return self._take()

    def _take(self) -> T | None:
        if not self._items:
            return None
        item = self._items.popleft()
        self._cond.notify_all()  # a producer waiting for room
        return item

    def __iter__(self) -> Iterator[T]:
        """Every item, as it comes, until the channel is closed and drained."""
        while (item := self.recv()) is not None:
            yield item

    def close(self) -> None:
        """No more items: a waiting producer and reader are released; what is kept can
        still be read."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()


class FifoChannel(Channel[T]):
    """Every item in order, up to ``capacity`` waiting; a full channel makes the producer
    wait for the reader (for a leader's deliveries: its polling waits too), so read it
    promptly or use a ``RingChannel``."""

    def __init__(self, capacity: int = 256) -> None:
        super().__init__(capacity, wait_when_full=True)


class RingChannel(Channel[T]):
    """The latest ``capacity`` items: a full channel drops its oldest, and the producer
    never waits (the freshest data, as polling for Age of Information wants)."""

    def __init__(self, capacity: int = 1) -> None:
        super().__init__(capacity, wait_when_full=False)


Handler: TypeAlias = Callable[[T], None] | Channel[T]
"""Where each item goes: a callable run on the producing thread, or a channel to read."""


def deliver_to(handler: Handler[T] | None) -> tuple[Callable[[T], None] | None, Channel[T] | None]:
    """(what the producer calls, the channel a reader reads or None) for ``handler``."""
    if isinstance(handler, Channel):
        return handler.put, handler
    if handler is not None and not callable(handler):
        raise TypeError(f"a handler is a callable, a FifoChannel or a RingChannel, not "
                        f"{type(handler).__name__}")
    return handler, None


class Receiver(Generic[T]):
    """Reading of what an owner (a ``Leader``, an ``Observer``) hands to its channel:
    ``recv``, ``try_recv`` and a ``for`` loop; a TypeError if its handler was a callable."""

    def __init__(self, channel: Channel[T] | None) -> None:
        self._channel = channel

    def _close_channel(self) -> None:
        """No more items: a producer waiting on a full FIFO goes on, a reader ends."""
        if self._channel is not None:
            self._channel.close()

    def _read(self) -> Channel[T]:
        if self._channel is None:
            raise TypeError(f"this {type(self).__name__} has no channel to read: open it "
                            "with a FifoChannel or RingChannel as its handler")
        return self._channel

    def recv(self, timeout: float | None = None) -> T | None:
        """The next item from the channel, waiting up to ``timeout`` seconds (None: until
        one comes or the owner closes); None if none came."""
        return self._read().recv(timeout)

    def try_recv(self) -> T | None:
        """The next item from the channel, or None at once."""
        return self._read().try_recv()

    def __iter__(self) -> Iterator[T]:
        """Every item from the channel until the owner is closed."""
        return iter(self._read())
