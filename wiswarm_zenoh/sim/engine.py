"""A tiny deterministic discrete-event engine in virtual time.

Events are ordered by (time, insertion counter), as in simpy's core, so two runs
with the same seed and the same calls give identical results. Callers that need to
cancel an event keep a version number and ignore stale callbacks; the engine
itself only orders and fires.
"""

from __future__ import annotations

import heapq
import random
from collections.abc import Callable
from itertools import count

Callback = Callable[[], None]


class Engine:
    """Runs callbacks in time order; ``now`` is the virtual time of the current event."""

    def __init__(self, seed: int) -> None:
        self.now = 0.0
        self.rng = random.Random(seed)
        self._heap: list[tuple[float, int, Callback]] = []
        self._counter = count()

    def at(self, time: float, callback: Callback) -> None:
        """Fire ``callback`` at virtual ``time`` (never earlier than now)."""
        if time < self.now:
            raise ValueError(f"cannot schedule in the past: {time} < now {self.now}")
        heapq.heappush(self._heap, (time, next(self._counter), callback))

    def after(self, delay: float, callback: Callback) -> None:
        """Fire ``callback`` ``delay`` seconds from now."""
        self.at(self.now + delay, callback)

    def peek(self) -> float:
        """Time of the next pending event (infinity if none)."""
        return self._heap[0][0] if self._heap else float("inf")

    def run(self, until: float) -> None:
        """Fire events in order up to and including time ``until``; then now = until."""
        heap = self._heap
        pop = heapq.heappop
        while heap and heap[0][0] <= until:
            time, _, callback = pop(heap)
            self.now = time
            callback()
        self.now = max(self.now, until)
