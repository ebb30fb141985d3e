"""Follower-side update queues and rate control (paper, Section II-B)."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from wiswarm_zenoh.core.config import DropRule, QueueKind
from wiswarm_zenoh.core.wire import checksum

GRID_TOLERANCE = 1e-6  # of an interval: absorbs float rounding of the producer's clock


@dataclass(slots=True)
class Update:
    """An application update, stamped when the middleware admitted it.

    Its checksum is taken here, once, on the producer's thread: a poll that sends the
    update then only copies it out. (Not frozen: one is made per update, and a frozen
    dataclass costs several times more to build.)
    """

    seq: int
    generated_at: float
    payload: bytes
    checksum: int = field(init=False)

    def __post_init__(self) -> None:
        self.checksum = checksum(self.payload)


class UpdateQueue:
    """A bounded FIFO or LIFO of updates.

    LIFO hands out the freshest update first; with capacity 1 it keeps only the freshest.
    A full FIFO applies its drop rule: ``tail`` refuses the arrival (a router's tail
    drop), ``head`` evicts the oldest to make room. A full LIFO always evicts its oldest.
    """

    def __init__(self, kind: QueueKind, capacity: int, drop: DropRule = "tail") -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.kind = kind
        self.capacity = capacity
        self.drop = drop
        self.dropped = 0
        self._items: deque[Update] = deque()

    def __len__(self) -> int:
        return len(self._items)

    def push(self, update: Update) -> bool:
        """Add an update; False if the drop rule refused it."""
        if len(self._items) >= self.capacity:
            self.dropped += 1
            if self.kind == "fifo" and self.drop == "tail":
                return False
            self._items.popleft()
        self._items.append(update)
        return True

    def peek(self) -> Update | None:
        """The update ``pop`` would return, without removing it."""
        if not self._items:
            return None
        return self._items[-1] if self.kind == "lifo" else self._items[0]

    def pop(self) -> Update | None:
        if not self._items:
            return None
        return self._items.pop() if self.kind == "lifo" else self._items.popleft()


class RateController:
    """Admits at most one update per interval on a fixed grid; drops those in between.

    The grid (start + k * interval) keeps the long-run rate exact even when the producer
    is faster and jittery, instead of drifting below the set rate.
    """

    def __init__(self, rate_hz: float) -> None:
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f"rate_hz must be a finite number > 0, got {rate_hz!r}")
        self.interval = 1.0 / rate_hz
        self._next: float | None = None

    def admit(self, now: float) -> bool:
        if self._next is None:
            self._next = now + self.interval
            return True
        if now < self._next - GRID_TOLERANCE * self.interval:
            return False
        missed = max(0, math.floor((now - self._next) / self.interval))
        self._next += (missed + 1) * self.interval
        return True
