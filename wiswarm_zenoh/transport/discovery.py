"""Liveliness tokens under a key expression, found even when Zenoh's first answer
misses one: the thin Zenoh shell around ``token_table``.

A watch (liveliness subscriber, history included) is declared first; its word on a
token stands until it says otherwise. Then the tokens are asked for again (a liveliness
get) every ``period`` seconds, every ``FAST_PERIOD`` while ``expecting()`` says one is
awaited (and for ``STARTING`` seconds from the start, when the watch's history is the
answer that can miss), slower with many tokens (``PER_TOKEN``). A token only an answer
brought is logged at INFO once, with why, and counts as any other. In peer mode, the
watch's history can lack a token that is there, and the watch then never hears of it:
a leader never polled a follower that was up until it was restarted (issue 40). In
client mode the router answers for all, and the answers only confirm what the watch
said.

``on_change(key, alive)`` is called on Zenoh's threads, in order, under this object's
lock: keep it short, and do not call back into it.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.token_table import TokenTable

log = logging.getLogger(__name__)

PERIOD = 0.4  # seconds between asks (the leader's stats round), with few tokens
FAST_PERIOD = 0.1  # seconds between asks while a token is awaited, with few tokens
# An answer costs the process some 7 us of Python per token, in a burst that holds the
# GIL from the poll threads: asked every 0.4 s at N = 1000, it took 6 % of the leader's
# polls/s (bench_scale --reask-pairs). So the pace slows with the tokens there, to a
# share of about 1 %: at most one ask per PER_TOKEN seconds per token (N = 1000: every
# 2 s), a quarter of that while one is awaited.
PER_TOKEN = 0.002
STARTING = 2.0  # seconds from the start asked at FAST_PERIOD: the history may have missed
ASK_TIMEOUT = 2.0  # seconds: the routers answer at once; an answer cut short says nothing
# Replies an answer may hold before it is read. A peer answers for the tokens it knows
# on the asking thread, before ``get`` returns: with more than the channel holds (Zenoh's
# default: 256), ``get`` never returns (eclipse-zenoh/zenoh#2678, open; seen here at
# N = 1000). A callback per reply instead takes the GIL a thousand times an answer.
REPLY_CAPACITY = 1 << 16


class Discovery:
    """The tokens under ``key_expr`` on ``session``, told to ``on_change`` as they come
    and go, until ``close()``; ``what`` names them in the log (``"follower token"``).
    ``period`` (default ``PERIOD``) may be changed at any time (a benchmark turns the
    asking off with a large one); ``reasks`` and ``found_by_answer`` count what asking did."""

    def __init__(self, session: zenoh.Session, key_expr: str,
                 on_change: Callable[[str, bool], object], what: str, *,
                 expecting: Callable[[], bool] = lambda: False) -> None:
        self._liveliness = session.liveliness()
        self._key_expr, self._on_change, self._what = key_expr, on_change, what
        self._period, self._expecting = PERIOD, expecting
        self._table = TokenTable()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._wake = threading.Event()  # the pace changed, or close: look again
        self.reasks = 0  # answers asked for after the watch's start
        self.found_by_answer = 0  # tokens an answer brought that the watch had missed
        self._started = time.monotonic()
        self._watch = self._liveliness.declare_subscriber(
            key_expr, zenoh.handlers.Callback(self._on_sample, indirect=False), history=True)
        self._thread = threading.Thread(target=self._run, name=f"discovery {key_expr}",
                                        daemon=True)
        self._thread.start()

    @property
    def period(self) -> float:
        return self._period

    @period.setter
    def period(self, seconds: float) -> None:
        self._period = seconds
        self._wake.set()

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key, alive = str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT
        with self._lock:
            if self._table.saw(key, alive):
                self._on_change(key, alive)

    def _run(self) -> None:
        while not self._stop.is_set():
            if self._wake.wait(self._wait()):
                self._wake.clear()  # a new pace (or close): wait on it from now
                continue
            self._ask()

    def _wait(self) -> float:
        """Seconds to the next ask: ``period``, or ``FAST_PERIOD`` while starting or a
        token is awaited, each at least ``PER_TOKEN`` per token there (a quarter of it
        when fast)."""
        tokens = len(self._table)
        if time.monotonic() - self._started < STARTING or self._expecting():
            return min(max(FAST_PERIOD, tokens * PER_TOKEN / 4), self._period)
        return max(self._period, tokens * PER_TOKEN)

    def _ask(self) -> None:
        """Ask which tokens are there now, and apply the answer once it is whole. The
        replies are read here from Zenoh's channel, not handed to a callback each: at
        N = 1000, a thousand callbacks each taking the GIL from the poll threads cost
        the leader polls (``REPLY_CAPACITY`` says why the channel is large)."""
        with self._lock:
            ticket = self._table.asking()
        self.reasks += 1
        keys = set()
        try:
            for reply in self._liveliness.get(self._key_expr,
                                              zenoh.handlers.FifoChannel(REPLY_CAPACITY),
                                              timeout=ASK_TIMEOUT):
                if reply.ok is None:
                    return  # a router's timeout: the answer is only part of it
                keys.add(str(reply.ok.key_expr))
        except zenoh.ZError:  # the session is closing
            return
        if not self._stop.is_set():
            self._apply(ticket, keys)

    def _apply(self, ticket: int, keys: set[str]) -> None:
        with self._lock:
            changes = self._table.answered(ticket, keys, time.monotonic())
            for key in changes.came:
                self.found_by_answer += 1
                log.info("%s %s found by asking again: the liveliness watch had missed it "
                         "(Zenoh's peer mode can leave a token out of an answer)",
                         self._what, key)
                self._on_change(key, True)
            for key in changes.went:
                log.info("%s %s gone: answers lacked it for %.0f s (the watch never saw it "
                         "come or go)", self._what, key, self._table.drop_seconds)
                self._on_change(key, False)

    def close(self) -> None:
        """Stop asking and watching (an answer still coming is ignored)."""
        self._stop.set()
        self._wake.set()
        self._thread.join()
        undeclare(self._watch)
