"""A follower's side of the control key, for any process that acts on control."""

from __future__ import annotations

import logging
import threading
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
    ``wiswarm/<swarm>/control`` newer than any before (the core follower judges), on
    Zenoh's thread; malformed messages are counted and logged in ``bad_input``.

    A ``FollowerNode`` listens through one; so does a process that sends its updates
    some other way (the push baseline) and still obeys the leader's control.
    """

    def __init__(self, session: zenoh.Session, swarm: str, follower_id: str,
                 on_control: ControlCallback | None = None,
                 bad_input: BadInputLog | None = None) -> None:
        self._core = Follower(follower_id)
        self._on_control = on_control
        self._lock = threading.Lock()
        self.bad_input = bad_input if bad_input is not None else BadInputLog(log)
        self._subscriber = session.declare_subscriber(SwarmKeys(swarm).control,
                                                      self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            with self._lock:
                entry = self._core.on_control(sample.payload.to_bytes())
        except WireError as exc:
            self.bad_input.report(str(sample.key_expr), str(exc))
            return
        if entry is not None and self._on_control is not None:
            self._on_control(entry)

    def close(self) -> None:
        undeclare(self._subscriber)
