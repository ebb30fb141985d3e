"""A fixed-rate loop on its own thread: a camera shutter, a metrics sampler."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

log = logging.getLogger(__name__)

MAX_RATE_HZ = 10_000.0


class Ticker:
    """Calls ``action(now)`` every ``1 / rate_hz`` seconds until ``stop()``. A late tick
    skips the ticks it missed instead of bursting to catch up (a camera drops frames; a
    burst of stale frames would only load the CPU). ``now`` comes from ``clock``; a tick
    that raises is logged and the next one comes on time."""

    def __init__(self, rate_hz: float, action: Callable[[float], object], name: str,
                 clock: Callable[[], float] = time.time) -> None:
        if not 0 < rate_hz <= MAX_RATE_HZ:
            raise ValueError(f"rate_hz must be in (0, {MAX_RATE_HZ:g}], got {rate_hz!r}")
        self.ticks = 0
        self._period = 1.0 / rate_hz
        self._action = action
        self._clock = clock
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        """Start calling the action in a thread of its own."""
        self._thread.start()

    def stop(self) -> None:
        """Stop calling it and wait for the thread."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        due = time.monotonic()
        while not self._stop.is_set():
            try:
                self._action(self._clock())
            except Exception:  # one bad tick must not stop the camera for good
                log.exception("%s: tick failed", self._thread.name)
            self.ticks += 1
            due += self._period
            late = time.monotonic() - due
            if late > self._period:
                due += (late // self._period) * self._period
            self._stop.wait(max(0.0, due - time.monotonic()))
