"""What a standby leader learns from the active one, so as to take over from it and not
from zero: its epoch, its last control information and the followers' weights.

It listens to what the active leader publishes anyway (``control``, each site's
``control/<site>``, and the followers' ``stats``); nothing is sent for it. Messages of
this process's own epoch are its own and ignored; a control message that does not decode
is ignored (the followers judge control; a standby only borrows from it)."""

from __future__ import annotations

import json
import logging
import threading

import zenoh

from wiswarm_zenoh.core import Waypoint, WireError
from wiswarm_zenoh.core.wire import decode_control
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

log = logging.getLogger(__name__)


class Handover:
    """The latest of the other leaders' state, for ``Leader.take_over``."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys) -> None:
        self.keys = keys
        self.own_epoch = -1  # this process's epoch: what it hears of it is its own
        self._lock = threading.Lock()
        self._epoch = -1  # the highest epoch heard from another leader
        self._control: dict[str, dict[str, list[Waypoint]]] = {}  # by key: a site's own
        self._weights: dict[str, float] = {}
        # Only other sessions' messages: this leader's own stats (one per follower 2.5
        # times a second) would otherwise be decoded here, beside its poll thread.
        remote = zenoh.Locality.REMOTE
        self._subscribers = [
            session.declare_subscriber(keys.control, self._on_control, allowed_origin=remote),
            session.declare_subscriber(keys.all_site_controls, self._on_control,
                                       allowed_origin=remote),
            session.declare_subscriber(keys.all_stats, self._on_stats, allowed_origin=remote),
        ]

    @property
    def epoch(self) -> int:
        """The highest epoch another leader used (-1: none heard)."""
        with self._lock:
            return self._epoch

    def state(self) -> tuple[int, dict[str, float], dict[str, list[Waypoint]]]:
        """(highest epoch heard, weights, last control) to take over with."""
        with self._lock:
            control = {f: w for entries in self._control.values() for f, w in entries.items()}
            return self._epoch, dict(self._weights), control

    def _on_control(self, sample: zenoh.Sample) -> None:
        try:
            control = decode_control(sample.payload.to_bytes())
        except WireError:
            return
        entries = {f: list(w) for f, w in control.entries.items()}
        with self._lock:
            if control.epoch == self.own_epoch or control.epoch < self._epoch:
                return
            if control.epoch > self._epoch:  # a new leader: what the old one sent is gone
                self._control = {}
            self._epoch = control.epoch
            self._control[str(sample.key_expr)] = entries

    def _on_stats(self, sample: zenoh.Sample) -> None:
        follower = self.keys.follower_of(str(sample.key_expr), "stats")
        try:
            weight = float(json.loads(sample.payload.to_bytes())["weight"])
        except (ValueError, KeyError, TypeError):
            return
        if follower is not None:
            with self._lock:
                self._weights[follower] = weight

    def close(self) -> None:
        undeclare(*self._subscribers)
