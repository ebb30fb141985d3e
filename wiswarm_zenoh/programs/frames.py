"""Synthetic camera frames, so a follower can be exercised without an application."""

from __future__ import annotations

import struct
import time
from collections.abc import Callable

from wiswarm_zenoh.programs.ticker import Ticker

FRAME_BYTES = 224 * 224  # one grayscale 224x224 frame, as in the paper's stationary runs
FRAME_RATE = 100.0
_HEADER = struct.Struct("<Qd")  # frame counter, capture time
FRAME_HEADER_BYTES = _HEADER.size


def capture_time(frame: bytes) -> float:
    """When a synthetic frame was captured (its sender's clock): ground truth for AoI,
    free of the leader's clock-offset estimate, where every node shares one clock."""
    if len(frame) < _HEADER.size:
        raise ValueError(f"a synthetic frame has at least {_HEADER.size} bytes, got {len(frame)}")
    captured_at: float = _HEADER.unpack_from(frame)[1]
    return captured_at


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
        self.frames = 0
        self._offer = offer
        self._filler = bytes(i % 251 for i in range(size - _HEADER.size))
        self._ticker = Ticker(rate, self._capture, "synthetic-frames", clock)

    def start(self) -> None:
        self._ticker.start()

    def stop(self) -> None:
        self._ticker.stop()

    def _capture(self, now: float) -> None:
        self.frames += 1
        self._offer(_HEADER.pack(self.frames, now) + self._filler)
