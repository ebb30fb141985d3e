"""What the baselines' tests share: a frame, a clock that ticks between calls, and a
waitable sink of what a receiver handed on (the FIFO and newest-only tests both use them)."""

from __future__ import annotations

import threading
import time

from tests.transport.helpers import WAIT

FRAME = bytes(range(256)) * 20


class Clock:
    """``time.time``, made to tick between calls: frames offered back to back in a test
    must not share a generation time (the second would not be fresher: stale)."""

    def __init__(self) -> None:
        self._last = 0.0
        self._lock = threading.Lock()

    def __call__(self) -> float:
        with self._lock:
            self._last = max(time.time(), self._last + 1e-6)
            return self._last


class Frames:
    """What a receiver handed on (its ``on_frame``), waitable."""

    def __init__(self) -> None:
        self.frames: list[tuple[str, bytes, float, float]] = []
        self.cond = threading.Condition()

    def __call__(self, follower: str, payload: bytes, generated_at: float, now: float) -> None:
        with self.cond:
            self.frames.append((follower, payload, generated_at, now))
            self.cond.notify_all()

    def of(self, follower: str) -> list[tuple[str, bytes, float, float]]:
        with self.cond:
            return [f for f in self.frames if f[0] == follower]

    def wait_for(self, followers: set[str], each: int) -> None:
        with self.cond:
            assert self.cond.wait_for(lambda: all(
                sum(f[0] == name for f in self.frames) >= each for name in followers),
                WAIT), f"fewer than {each} frames from each of {followers}"
