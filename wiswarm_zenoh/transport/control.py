"""A follower's side of the control key, for any process that acts on control."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.core import Follower, Waypoint, WireError
from wiswarm_zenoh.core.wire import Control, decode_control
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

log = logging.getLogger(__name__)

ControlCallback = Callable[[list[Waypoint]], None]


class ControlListener:
    """Hands ``on_control`` this follower's entry of every control message on its
    control key (``wiswarm/<swarm>/control``; a site's follower in a cloud, named
    ``<site>.<follower>``, its site's ``control/<site>``) that the core follower says to
    obey, on Zenoh's thread;
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
        self._heard_at = time.monotonic()  # when the last control message came
        self._after_gap_until = 0.0  # messages before this are expected to be stale
        self._shared = SessionControl.join(session, SwarmKeys(swarm).control_of(follower_id),
                                           self)

    def take(self, control: Control, key: str) -> None:
        """A control message on ``key``, decoded once for every listener of the session.
        After a gap of more than ``RESUME_GAP`` with no control (this process was
        stopped, or cut off), the messages queued meanwhile come stamped too far from
        their leader's clock: expected, counted, and said at INFO."""
        heard = time.monotonic()
        if heard - self._heard_at > RESUME_GAP:
            self._after_gap_until = heard + RESUME_GAP
        self._heard_at = heard
        try:
            with self._lock:
                entry = self._core.take_control(control, self._clock())
        except WireError as exc:
            expected = heard < self._after_gap_until
            self.bad_input.report(key, str(exc) + (" (queued while this follower was "
                                                   "stopped or cut off)" if expected else ""),
                                  expected)
            return
        if entry is not None and self._on_control is not None:
            self._on_control(entry)

    def close(self) -> None:
        """Stop listening to control."""
        self._shared.leave(self)


RESUME_GAP = 1.0  # seconds without control (repeated every 0.1 s) that make a gap

_SHARED: dict[tuple[zenoh.Session, str], SessionControl] = {}
_SHARED_LOCK = threading.Lock()


class SessionControl:
    """A session's one subscription to a swarm's control, shared by every listener on
    it: a process hosting hundreds of followers decodes each message once, on one
    thread, instead of waking a thread per follower to decode it again (which made
    their polls wait long enough to time out)."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self.session, self.key = session, key
        self.listeners: list[ControlListener] = []
        self.subscriber = session.declare_subscriber(key, self._on_sample)

    @staticmethod
    def join(session: zenoh.Session, key: str, listener: ControlListener) -> SessionControl:
        with _SHARED_LOCK:
            shared = _SHARED.get((session, key))
            if shared is None:
                shared = _SHARED[(session, key)] = SessionControl(session, key)
            shared.listeners.append(listener)
            return shared

    def leave(self, listener: ControlListener) -> None:
        with _SHARED_LOCK:
            self.listeners.remove(listener)
            if self.listeners:
                return
            del _SHARED[(self.session, self.key)]
        undeclare(self.subscriber)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        with _SHARED_LOCK:
            listeners = list(self.listeners)
        try:
            control = decode_control(sample.payload.to_bytes())
        except WireError as exc:
            for listener in listeners:
                listener.bad_input.report(key, str(exc))
            return
        for listener in listeners:
            listener.take(control, key)
