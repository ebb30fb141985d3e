"""A follower's side of the control key, for any process that acts on control."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.core import Follower, Waypoint, WireError
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

log = logging.getLogger(__name__)

ControlCallback = Callable[[list[Waypoint]], None]


class ControlListener:
    """Hands ``on_control`` this follower's entry of every control message on
    ``wiswarm/<swarm>/control`` that the core follower says to obey, on Zenoh's thread;
    malformed and implausible messages are counted and logged in ``bad_input``.

    A ``FollowerNode`` listens through one, sharing its core (which knows the leader's
    clock from the polls it answered) and lock; so does a process that sends its updates
    some other way (the push baseline) and still obeys the leader's control.
    """

    def __init__(self, session: zenoh.Session, swarm: str, follower_id: str,
                 on_control: ControlCallback | None = None,
                 bad_input: BadInputLog | None = None, *, core: Follower | None = None,
                 lock: threading.Lock | None = None,
                 clock: Callable[[], float] = time.time) -> None:
        self._core = core if core is not None else Follower(follower_id)
        self._on_control = on_control
        self._lock = lock if lock is not None else threading.Lock()
        self._clock = clock
        self.bad_input = bad_input if bad_input is not None else BadInputLog(log)
        self._subscriber = session.declare_subscriber(SwarmKeys(swarm).control,
                                                      self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            data = sample.payload.to_bytes()
            with self._lock:
                entry = self._core.on_control(data, self._clock())
        except WireError as exc:
            self.bad_input.report(str(sample.key_expr), str(exc))
            return
        if entry is not None and self._on_control is not None:
            self._on_control(entry)

    def close(self) -> None:
        undeclare(self._subscriber)
