"""What the transport tests share: a recorder of LeaderNode callbacks, loopback sessions."""

from __future__ import annotations

import itertools
import json
import statistics
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, cast

import zenoh

from wiswarm_zenoh.core import Delivered
from wiswarm_zenoh.transport import SessionSpec

WAIT = 15.0  # seconds: generous, since the machine may be busy; met in well under 1 s


@dataclass
class Recorder:
    """Everything a LeaderNode reports through its callbacks, waitable."""

    deliveries: list[Delivered] = field(default_factory=list)
    joins: list[str] = field(default_factory=list)
    leaves: list[str] = field(default_factory=list)
    cond: threading.Condition = field(default_factory=threading.Condition)

    def on_delivery(self, event: Delivered) -> None:
        with self.cond:
            self.deliveries.append(event)
            self.cond.notify_all()

    def on_join(self, follower: str) -> None:
        with self.cond:
            self.joins.append(follower)
            self.cond.notify_all()

    def on_leave(self, follower: str) -> None:
        with self.cond:
            self.leaves.append(follower)
            self.cond.notify_all()

    def callbacks(self) -> dict[str, Callable[..., None]]:
        return {"on_delivery": self.on_delivery, "on_join": self.on_join,
                "on_leave": self.on_leave}

    def count(self, follower: str) -> int:
        with self.cond:
            return sum(d.follower == follower for d in self.deliveries)

    def wait(self, what: str, predicate: Callable[[Recorder], bool],
             timeout: float = WAIT) -> None:
        with self.cond:
            assert self.cond.wait_for(lambda: predicate(self), timeout), f"timed out: {what}"


class Sessions:
    """Opens loopback sessions and closes them all at the end of the test."""

    def __init__(self) -> None:
        self.opened: list[zenoh.Session] = []

    def open(self, spec: SessionSpec) -> zenoh.Session:
        session = spec.open()
        self.opened.append(session)
        return session

    def router(self, port: int) -> zenoh.Session:
        return self.open(SessionSpec.loopback("router", port))

    def node(self, port: int, mode: str = "peer") -> zenoh.Session:
        return self.open(SessionSpec.loopback(mode, connect_ports=[port]))

    def close_all(self) -> None:
        for session in reversed(self.opened):
            if not session.is_closed():
                session.close()


class Samples:
    """A plain subscriber keeping every sample it gets, waitable (any tool could do this)."""

    def __init__(self, session: zenoh.Session, key_expr: str) -> None:
        self.samples: list[zenoh.Sample] = []
        self.arrivals: list[float] = []  # time.monotonic() as each sample came
        self.cond = threading.Condition()
        self._subscriber = session.declare_subscriber(key_expr, self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        with self.cond:
            self.samples.append(sample)
            self.arrivals.append(time.monotonic())
            self.cond.notify_all()

    def rate(self, key: str) -> tuple[float, int]:
        """Samples of ``key`` per second, from the median time between two (one sample
        held up on a busy machine makes one gap longer and the next shorter, and leaves
        the median), and how many of them were copies of another (the same payload
        twice: a second path)."""
        with self.cond:
            mine = [(t, s.payload.to_bytes()) for t, s in zip(self.arrivals, self.samples,
                                                                strict=True)
                    if str(s.key_expr) == key]
        gaps = [b[0] - a[0] for a, b in itertools.pairwise(mine)]
        gap = statistics.median(gaps) if gaps else 0.0
        return (1 / gap if gap > 0 else 0.0, len(mine) - len({payload for _, payload in mine}))

    def stats(self, key: str) -> list[dict[str, Any]]:
        with self.cond:
            return [json.loads(s.payload.to_bytes()) for s in self.samples
                    if str(s.key_expr) == key]

    def wait(self, what: str, predicate: Callable[[Samples], bool],
             timeout: float = WAIT) -> None:
        with self.cond:
            assert self.cond.wait_for(lambda: predicate(self), timeout), f"timed out: {what}"


def wait_until_known(session: zenoh.Session, key: str) -> None:
    """Until ``session`` knows of a subscriber to ``key``: declarations travel through
    the router, and a put made before reaches nobody (``fresh`` is not even sent)."""
    known = threading.Event()
    publisher = session.declare_publisher(key)
    listener = publisher.declare_matching_listener(
        zenoh.handlers.Callback(lambda status: status.matching and known.set(), indirect=False)
    )
    status = cast(zenoh.MatchingStatus, publisher.matching_status)  # the stubs say bool
    if status.matching:
        known.set()
    try:
        assert known.wait(WAIT), f"no subscriber to {key} reached this session"
    finally:
        listener.undeclare()
        publisher.undeclare()


def eventually(what: str, check: Callable[[], bool]) -> None:
    """Until ``check()``, for a state that no callback announces (a log line, a counter
    set on Zenoh's thread): looked at every millisecond, up to WAIT."""
    deadline = time.monotonic() + WAIT
    while not check():
        assert time.monotonic() < deadline, f"timed out: {what}"
        time.sleep(0.001)
