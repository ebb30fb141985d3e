"""A camera that produces frames at a fixed rate into an application FIFO, or into a
slot of one that keeps the newest (``PeriodicNewest``).

Frames are admitted lazily, when the sender asks for one: frames generated since the
last request enter the FIFO until it is full and the rest are dropped at the tail,
which is exactly what an eager FIFO would hold at that moment. The FIFO is stored as
runs of consecutive frame numbers, so an unbounded backlog costs O(1) memory.
"""

from __future__ import annotations

import math
from collections import deque


class PeriodicFifo:
    """Frames generated at ``phase + k / rate`` (k = 0, 1, ...) in a tail-drop FIFO."""

    def __init__(self, rate: float, phase: float, capacity: int | None) -> None:
        if rate <= 0 or not math.isfinite(rate):
            raise ValueError(f"rate must be positive, got {rate}")
        if capacity is not None and capacity < 1:
            raise ValueError(f"capacity must be >= 1 or None, got {capacity}")
        self.period = 1.0 / rate
        self.phase = phase
        self.capacity = capacity
        self._runs: deque[list[int]] = deque()  # [first, end) frame numbers, oldest first
        self._considered = 0  # frames generated so far that were admitted or dropped
        self._length = 0
        self.dropped = 0

    def generated(self, now: float) -> int:
        """Frames generated at or before ``now``."""
        if now < self.phase:
            return 0
        return math.floor((now - self.phase) / self.period + 1e-9) + 1

    def _admit(self, now: float) -> None:
        total = self.generated(now)
        new = total - self._considered
        if new <= 0:
            return
        take = new if self.capacity is None else min(new, self.capacity - self._length)
        if take > 0:
            runs = self._runs
            if runs and runs[-1][1] == self._considered:
                runs[-1][1] += take
            else:
                runs.append([self._considered, self._considered + take])
            self._length += take
        self.dropped += new - take
        self._considered = total

    def __len__(self) -> int:
        return self._length

    def pull(self, now: float) -> float | None:
        """Remove the oldest frame and return its generation time; None if empty."""
        self._admit(now)
        if not self._runs:
            return None
        run = self._runs[0]
        frame = run[0]
        run[0] += 1
        if run[0] == run[1]:
            self._runs.popleft()
        self._length -= 1
        return self.phase + frame * self.period

    def next_frame_time(self, now: float) -> float:
        """Generation time of the first frame after ``now``."""
        return self.phase + self.generated(now) * self.period


class PeriodicNewest(PeriodicFifo):
    """The newest-only baseline's camera: a slot of one where a newer frame replaces the
    one waiting (``dropped`` counts the frames replaced unsent), so ``pull`` gives the
    newest frame not yet pulled."""

    def __init__(self, rate: float, phase: float) -> None:
        super().__init__(rate, phase, 1)

    def _admit(self, now: float) -> None:
        total = self.generated(now)
        new = total - self._considered
        if new <= 0:
            return
        self.dropped += self._length + new - 1
        self._runs.clear()
        self._runs.append([total - 1, total])
        self._length = 1
        self._considered = total
