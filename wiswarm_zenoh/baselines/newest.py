"""Newest-only push, the adaptive baseline a careful engineer tries before polling: each
robot keeps only its newest frame and sends it the moment its previous send completed.
There is no rate to tune (the sends come as fast as the path takes them, since a send
blocks while the path is full), yet nobody decides who talks: every robot sends
whenever it can, which is what polling is compared with.

``NewestSlot`` is the rule, without I/O: a newer frame replaces the one waiting, an
older one never does (refused and counted: samples that overtook each other on the way,
or a clock that went back). Sequence numbers go to the frames taken to be sent, so a
gap at the receiver is still a frame lost on the way, as with the FIFO. ``NewestPump``
runs it: a thread takes the slot, sends, and takes it again (``fifo.FramePump``).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Generic

from wiswarm_zenoh.baselines.fifo import FramePump, P, Send

# Bytes of SO_SNDBUF beneath a newest-only sender (the kernel doubles it): well under a
# frame, so that a frame waits in the slot, where a newer one replaces it, not in the
# kernel; yet a few milliseconds of a 20 Mbit/s link, enough to keep it busy. Over TCP
# on the tbf channel (20 Mbit/s, N = 4, 50 KB frames at 100 fps): mean AoI 161 ms,
# against 7.3 s with 4 MiB (about what the kernel autotunes to), at the same throughput.
NEWEST_SEND_BUFFER = 16384

class NewestSlot(Generic[P]):
    """A slot of one frame. ``offered``, ``replaced`` (waiting, never sent: a newer one
    came), ``refused`` (older than one offered before) and ``sent`` (taken to be sent)
    count the frames."""

    def __init__(self) -> None:
        self.offered = self.replaced = self.refused = self.sent = 0
        self._waiting: tuple[P, float] | None = None
        self._newest: float = -math.inf  # the order of the newest frame offered

    @property
    def waiting(self) -> bool:
        return self._waiting is not None

    def offer(self, payload: P, generated_at: float, stamp: int | None = None) -> bool:
        """Hold ``payload``, generated at ``generated_at``, in place of the frame waiting;
        False (refused) if it is older than a frame offered before. ``stamp``: the source's
        own integer time, which orders the frames instead when given: an epoch time in ns
        as a float in seconds is 238 ns coarse, and a sample 1 ns older than the one
        waiting replaced it."""
        self.offered += 1
        order = generated_at if stamp is None else stamp
        if order < self._newest:
            self.refused += 1
            return False
        if self._waiting is not None:
            self.replaced += 1
        self._waiting, self._newest = (payload, generated_at), order
        return True

    def take(self) -> tuple[P, float, int] | None:
        """The frame waiting with its sequence number, leaving the slot empty; None if
        none waits."""
        if self._waiting is None:
            return None
        (payload, generated_at), self._waiting = self._waiting, None
        self.sent += 1
        return payload, generated_at, self.sent

    def clear(self) -> None:
        """Drop the frame waiting, if any (a sender that stops)."""
        self._waiting = None


class NewestPump(FramePump[P]):
    """A ``NewestSlot`` and the thread that sends what it holds: ``offer`` never waits."""

    def __init__(self, name: str, send: Send[P], clock: Callable[[], float] = time.time,
                 release: Callable[[], None] = lambda: None) -> None:
        self.slot: NewestSlot[P] = NewestSlot()
        self._clock = clock
        self._cond = threading.Condition()  # the slot, between offers and the thread
        self._closed = False
        super().__init__(name, send, release)

    def offer(self, payload: P, generated_at: float | None = None,
              stamp: int | None = None) -> bool:
        """Hold ``payload`` (generated now, unless told) for the next send; False if it is
        older than a frame offered before (by ``stamp``, if given: ``NewestSlot``)."""
        with self._cond:
            held = self.slot.offer(payload, self._clock() if generated_at is None
                                   else generated_at, stamp)
            self._cond.notify()
        return held

    def _next(self) -> tuple[P, float, int] | None:
        with self._cond:
            self._cond.wait_for(lambda: self._closed or self.slot.waiting)
            return None if self._closed else self.slot.take()

    def _shut(self) -> None:
        with self._cond:
            self._closed = True
            self.slot.clear()
            self._cond.notify()

    @property
    def counts(self) -> str:
        slot = self.slot
        return (f"{slot.offered} frames offered, {self.sent} sent, {slot.replaced} replaced "
                f"unsent by a newer one, {slot.refused} refused as older")
