"""Ends the get the poll thread waits on once its deadline passes.

Blocked in a channel's ``recv`` (``steady_gets``), the poll thread cannot look at the
clock, so this thread does: armed by one attribute write per poll, it wakes at the
watched deadline and, if that poll is still the one waited on, cancels its get (the
channel closes, ``recv`` returns). A deadline is ``timeout_floor`` (10 ms) or more after
its poll went out, so while polls are answered it wakes about once per floor, to sleep
on to the newer poll's deadline, not once per poll.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

CANCEL_RETRY = 0.001  # seconds between looks while a cancelled get is still watched


class Cancellable(Protocol):
    """A get's ``Cancellable`` (its stub leaves ``cancel`` unannotated)."""

    def cancel(self) -> None: ...


class DeadlineWatch:
    """Cancels a watched get at its deadline (one watched at a time)."""

    def __init__(self, clock: Callable[[], float], name: str) -> None:
        self._clock = clock
        self._watched: tuple[float, Cancellable] | None = None
        self._idle = False  # the thread waits for a watch (``watch`` must wake it)
        self._wake = threading.Event()
        self._stopped = False
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def watch(self, deadline: float, token: Cancellable) -> None:
        """Cancel ``token`` at ``deadline`` unless another watch (or ``clear``) comes first."""
        self._watched = (deadline, token)
        if self._idle:
            self._wake.set()

    def clear(self) -> None:
        self._watched = None

    def close(self) -> None:
        """Stop watching; the get watched now is cancelled (the poll thread is let go)."""
        self._stopped = True
        watched = self._watched
        if watched is not None:
            watched[1].cancel()
        self._wake.set()
        self._thread.join()

    def _run(self) -> None:
        cancelled: tuple[float, Cancellable] | None = None
        while not self._stopped:
            watched = self._watched
            if watched is None:
                self._idle = True
                if self._watched is None and not self._stopped:  # else ``watch`` saw idle
                    self._wake.wait()
                self._wake.clear()
                self._idle = False
                continue
            delay = watched[0] - self._clock()
            if delay > 0.0:
                self._wake.wait(delay)
                self._wake.clear()
            elif watched is cancelled:  # the poll thread has not moved on yet
                self._wake.wait(CANCEL_RETRY)
            else:
                watched[1].cancel()
                cancelled = watched
