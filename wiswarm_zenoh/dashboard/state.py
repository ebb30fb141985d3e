"""What the dashboard knows of a swarm, kept so that a browser that connects (or comes
back) is shown the last 30 s at once, then every change as it comes.

Every change is handed to ``emit`` as the message the browsers get, under the same lock
as the change itself, and ``emit`` numbers it: a snapshot carries the number of the last
change it includes, so a new browser gets each change exactly once (in the snapshot, or
after it). Times of deliveries are the leader's clock; the others the dashboard's.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from wiswarm_zenoh.dashboard.records import Record
from wiswarm_zenoh.transport.badinput import BadInputLog

log = logging.getLogger(__name__)

Message = dict[str, Any]
Emit = Callable[[Message], int]  # hands a message on; returns its number
Delivery = tuple[str, float | None, float]  # follower, generated_at (None: timeout), delivered_at

WINDOW_S = 30.0  # seconds of sawtooth shown
KEPT_S = WINDOW_S + 5.0  # seconds of deliveries kept: the window, and its left edge's lead-in
LEADER_SILENCE_S = 2.0  # leader stats missing this long: "no leader since ..."
RATE_SPAN_S = 1.0  # polls/s are taken over at least this long
MAX_FOLLOWERS = 2000  # beyond this, new names are refused (a rogue inventing them)
MAX_RECORDS = 100_000  # deliveries kept per follower (a leader polling one at 3 kHz)
MAX_UAVS = 200
MAX_RUNS = 20  # experiment runs kept (the oldest go)


@dataclass
class Trace:
    """One follower's deliveries over the last KEPT_S, and the freshest generation time
    of those dropped before them (where the sawtooth enters the window)."""

    records: deque[tuple[float | None, float]] = field(default_factory=deque)
    tau: float | None = None

    def add(self, generated: float | None, delivered: float) -> None:
        if len(self.records) >= MAX_RECORDS:
            self._drop()
        self.records.append((generated, delivered))

    def prune(self, before: float) -> None:
        while self.records and self.records[0][1] < before:
            self._drop()

    def _drop(self) -> None:
        generated, _ = self.records.popleft()
        if generated is not None and (self.tau is None or generated > self.tau):
            self.tau = generated


@dataclass
class PollRate:
    """Polls per second of one follower, from the ``polls`` counter of its stats."""

    mark: tuple[float, int] | None = None  # (when, polls) at the last rate taken
    rate: float | None = None

    def observe(self, now: float, polls: int) -> float | None:
        if self.mark is None or polls < self.mark[1]:  # first, or a new leader's count
            self.mark, self.rate = (now, polls), None
        elif now - self.mark[0] >= RATE_SPAN_S:
            self.rate = (polls - self.mark[1]) / (now - self.mark[0])
            self.mark = (now, polls)
        return self.rate


class SwarmState:
    """Thread-safe: Zenoh's threads change it, the web server reads snapshots."""

    def __init__(self, swarm: str, emit: Emit, clock: Callable[[], float] = time.time,
                 window_s: float = WINDOW_S) -> None:
        self.swarm = swarm
        self.window_s = window_s
        self._emit = emit
        self._clock = clock
        self._lock = threading.Lock()
        self._seq = 0  # number of the last message emitted
        self._traces: dict[str, Trace] = {}
        self._stream_clock = float("-inf")  # the latest delivery time heard (leader clock)
        self._stats: dict[str, Record] = {}
        self._rates: dict[str, PollRate] = {}
        self._leader: Record | None = None
        self._leader_seen_at: float | None = None
        self._started_at = clock()
        self._finished_at: float | None = None  # when the feed stopped for good
        self._tracking: dict[str, Record] = {}
        self._runs: dict[str, Record] = {}
        self.bad_input = BadInputLog(log)  # the feed reports to it, the browsers see its total

    def _send(self, message: Message) -> None:
        self._seq = self._emit(message)

    def add_deliveries(self, deliveries: Sequence[Delivery]) -> int:
        """Keep and pass on a batch; returns how many were refused (a new follower past
        MAX_FOLLOWERS)."""
        refused = 0
        kept: list[Delivery] = []
        with self._lock:
            for follower, generated, delivered in deliveries:
                trace = self._traces.get(follower)
                if trace is None:
                    if len(self._traces) >= MAX_FOLLOWERS:
                        refused += 1
                        continue
                    trace = self._traces[follower] = Trace()
                trace.add(generated, delivered)
                self._stream_clock = max(self._stream_clock, delivered)
                kept.append((follower, generated, delivered))
            for trace in self._traces.values():
                trace.prune(self._stream_clock - KEPT_S)
            if kept:
                self._send({"type": "deliveries", "records": kept})
        return refused

    def set_stats(self, record: Record) -> bool:
        """A follower's stats, with its polls/s added; False if refused (too many)."""
        follower = record["follower"]
        with self._lock:
            if follower not in self._stats and len(self._stats) >= MAX_FOLLOWERS:
                return False
            rate = self._rates.setdefault(follower, PollRate())
            polls = record.get("polls")
            record["polls_per_s"] = None if polls is None else rate.observe(self._clock(), polls)
            self._stats[follower] = record
            self._send({"type": "stats", "record": record})
        return True

    def set_leader(self, record: Record) -> None:
        with self._lock:
            self._leader, self._leader_seen_at = record, self._clock()
            self._send({"type": "leader", "record": record, "seen_at": self._leader_seen_at})

    def set_tracking(self, record: Record) -> bool:
        with self._lock:
            if record["uav"] not in self._tracking and len(self._tracking) >= MAX_UAVS:
                return False
            self._tracking[record["uav"]] = record
            self._send({"type": "tracking", "record": record})
        return True

    def set_run(self, record: Record) -> None:
        """An experiment run's points so far (the oldest run goes past MAX_RUNS)."""
        with self._lock:
            self._runs.pop(record["run"], None)
            self._runs[record["run"]] = record
            while len(self._runs) > MAX_RUNS:
                del self._runs[next(iter(self._runs))]
            self._send({"type": "run", "record": record})

    def finish(self) -> None:
        """Nothing more will come (the run shown has ended): the browsers are told, so
        that they show the last state as it was instead of letting it age out of view."""
        with self._lock:
            self._finished_at = self._clock()
            self._send(self._status())

    def status(self) -> None:
        """Pass on whether a leader is heard (and since when not), and the counters."""
        with self._lock:
            self._send(self._status())

    def _status(self) -> Message:
        now = self._clock()
        seen = self._leader_seen_at
        message: Message = {
            "type": "status", "now": now, "started_at": self._started_at,
            "leader_seen_at": seen,
            "leader_alive": seen is not None and now - seen <= LEADER_SILENCE_S,
            "bad_input": self.bad_input.total()}
        if self._finished_at is not None:  # only then: a live swarm's status is unchanged
            message["finished_at"] = self._finished_at
        return message

    def snapshot(self) -> tuple[Message, int]:
        """Everything a new browser needs, and the number of the last change in it."""
        with self._lock:
            return {
                "type": "snapshot", "swarm": self.swarm, "window_s": self.window_s,
                "traces": {f: {"tau": t.tau, "records": list(t.records)}
                           for f, t in self._traces.items()},
                "stats": list(self._stats.values()), "leader": self._leader,
                "tracking": list(self._tracking.values()), "runs": list(self._runs.values()),
                "status": self._status(),
            }, self._seq
