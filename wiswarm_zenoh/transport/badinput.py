"""Malformed network input: counted per sender key, logged without flooding the log."""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from collections.abc import Callable


class BadInputLog:
    """Counts every bad message per key; logs at most one line per key per ``interval``
    (a rogue replying garbage to a thousand polls a second must not drown the log)."""

    def __init__(self, logger: logging.Logger, interval: float = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.counts: Counter[str] = Counter()
        self._logger = logger
        self._interval = interval
        self._clock = clock
        self._last: dict[str, float] = {}
        self._quiet: Counter[str] = Counter()
        self._lock = threading.Lock()

    def report(self, key: str, reason: str, expected: bool = False) -> None:
        """Count a bad message from ``key``; ``expected``: a known consequence of
        something that happened here (logged at INFO), not a sender to look at."""
        now = self._clock()
        with self._lock:
            self.counts[key] += 1
            last = self._last.get(key)
            if last is not None and now - last < self._interval:
                self._quiet[key] += 1
                return
            self._last[key] = now
            quiet = self._quiet.pop(key, 0)
        more = f" (and {quiet} more since the last report)" if quiet else ""
        level = logging.INFO if expected else logging.WARNING
        self._logger.log(level, "bad input from %s: %s%s", key, reason, more)

    def total(self) -> int:
        """Bad messages counted so far, over every key."""
        with self._lock:
            return sum(self.counts.values())
