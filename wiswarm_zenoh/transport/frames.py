"""Synthetic camera frames, so a follower can be exercised without an application."""

from __future__ import annotations

import logging
import struct
import threading
import time
from collections.abc import Callable

log = logging.getLogger(__name__)

FRAME_BYTES = 224 * 224  # one grayscale 224x224 frame, as in the paper's stationary runs
FRAME_RATE = 100.0
_HEADER = struct.Struct("<Qd")  # frame counter, capture time
FRAME_HEADER_BYTES = _HEADER.size


class SyntheticFrames:
    """Offers a frame of ``size`` bytes every ``1/rate`` seconds from its own thread.

    Each frame starts with its counter and capture time; the rest is a fixed pattern.
    A late thread skips the frames it missed rather than bursting to catch up, as a
    camera would.
    """

    def __init__(self, offer: Callable[[bytes], bool], size: int = FRAME_BYTES,
                 rate: float = FRAME_RATE, clock: Callable[[], float] = time.time) -> None:
        if size < _HEADER.size:
            raise ValueError(f"frame size must be >= {_HEADER.size} bytes, got {size}")
        if not rate > 0:
            raise ValueError(f"frame rate must be > 0, got {rate}")
        self.frames = 0
        self._offer = offer
        self._period = 1.0 / rate
        self._clock = clock
        self._filler = bytes(i % 251 for i in range(size - _HEADER.size))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="synthetic-frames", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        due = time.monotonic()
        while not self._stop.is_set():
            self.frames += 1
            self._offer(_HEADER.pack(self.frames, self._clock()) + self._filler)
            due += self._period
            late = time.monotonic() - due
            if late > self._period:
                due += (late // self._period) * self._period
            self._stop.wait(max(0.0, due - time.monotonic()))
