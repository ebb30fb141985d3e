"""A follower that stops answering, said at WARNING only once its silence lasts.

The core calls a follower silent after a window of unanswered polls: at hundreds of polls
a second that is a few tens of milliseconds. A busy host, or routes settling as a peer
link comes up, makes a follower miss that many and answer again at once: nothing for a
user to act on, so that is INFO. A follower still silent after ``SILENCE_GRACE`` (and
still a member: one that left says so itself; one that rejoined is polled afresh) is the
WARNING."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

log = logging.getLogger("wiswarm_zenoh.transport.leader_node")  # where users look for it

SILENCE_GRACE = 1.0  # seconds a follower may stay silent before the warning


class SilenceLog:
    """Warns of a silent follower after ``grace`` unless it answered again (or
    ``relevant(follower)`` is False by then: it left, or the leader stopped)."""

    def __init__(self, relevant: Callable[[str], bool], grace: float = SILENCE_GRACE) -> None:
        self._relevant = relevant
        self._grace = grace
        self._lock = threading.Lock()
        self._pending: dict[str, tuple[threading.Timer, int, float]] = {}

    def silent(self, follower: str, polls: int) -> None:
        """``follower`` missed its last ``polls`` polls."""
        timer = threading.Timer(self._grace, self._warn, args=(follower,))
        timer.daemon = True
        with self._lock:
            old = self._pending.get(follower)
            self._pending[follower] = (timer, polls, time.monotonic())
        if old is not None:
            old[0].cancel()
        timer.start()

    def answering(self, follower: str, silent_for: float) -> None:
        """``follower`` answered again after ``silent_for`` seconds."""
        with self._lock:
            pending = self._pending.pop(follower, None)
        if pending is None:  # the warning was given
            log.info("follower %s answers again, after %.1f s", follower, silent_for)
            return
        pending[0].cancel()
        log.info("follower %s missed %d polls and answers again, after %.2f s", follower,
                 pending[1], silent_for)

    def rejoined(self, follower: str) -> None:
        """``follower`` left and joined again (a new process, or a router restarted): the
        join took its silence away (its missed polls are forgotten) without an answer,
        so a warning still pending would come while it answers."""
        with self._lock:
            pending = self._pending.pop(follower, None)
        if pending is not None:
            pending[0].cancel()

    def _warn(self, follower: str) -> None:
        with self._lock:
            pending = self._pending.pop(follower, None)
        if pending is None or not self._relevant(follower):
            return
        log.warning("follower %s stopped answering (its last %d polls went unanswered, "
                    "and nothing in %.1f s since): probing it alone now", follower,
                    pending[1], time.monotonic() - pending[2])
