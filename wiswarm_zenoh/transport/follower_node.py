"""A follower on Zenoh: the core follower behind a queryable, a subscriber and a token."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from types import TracebackType

import zenoh

from wiswarm_zenoh.core import Follower, FollowerConfig, WireError
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.control import ControlCallback, ControlListener
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

log = logging.getLogger(__name__)


class FollowerNode:
    """Answers the leader's polls (``wiswarm/<swarm>/<id>/update``) with the core's reply,
    hands its own entry of ``wiswarm/<swarm>/control`` to ``on_control``, and holds the
    liveliness token ``wiswarm/<swarm>/members/<id>`` while it is up.

    ``on_control`` is called on Zenoh's thread with this follower's waypoints, a list of
    ``(t, x, y, z)`` (``Waypoint``), for every control message that carries an entry for
    it and that it obeys (the leader repeats its control every 0.1 s).

    ``offer`` is thread-safe and may be called at any rate. ``clock`` stamps updates
    and polls (the leader estimates its offset). With ``sample_on_poll`` the node takes
    a fresh sample from it whenever polled (a sensor read at will) before answering.
    """

    def __init__(
        self,
        session: zenoh.Session,
        swarm: str,
        follower_id: str,
        config: FollowerConfig | None = None,
        *,
        on_control: ControlCallback | None = None,
        clock: Callable[[], float] = time.time,
        sample_on_poll: Callable[[], bytes] | None = None,
    ) -> None:
        self.keys = SwarmKeys(swarm)
        self.follower_id = follower_id
        self._session = session  # held: a session nobody references is closed
        self._key = zenoh.KeyExpr(self.keys.update(follower_id))  # parsed once, not per reply
        self._core = Follower(follower_id, config)
        self._clock = clock
        self._sample = sample_on_poll
        self._lock = threading.Lock()
        self.bad_input = BadInputLog(log)
        # The queryable runs on Zenoh's own thread: answering is a few tens of
        # microseconds, and a hop to another thread would add to every poll.
        self._queryable = session.declare_queryable(
            self._key, zenoh.handlers.Callback(self._on_query, indirect=False)
        )
        self._control = ControlListener(session, swarm, follower_id, on_control, self.bad_input,
                                        core=self._core, lock=self._lock, clock=clock)
        self._token = session.liveliness().declare_token(self.keys.member(follower_id))
        log.info("follower %s up on %s", follower_id, self._key)

    def offer(self, payload: bytes, generated_at: float | None = None) -> bool:
        """Queue an update stamped now, or at ``generated_at`` (this node's clock: an
        update made elsewhere and relayed, see ``edge``); False if rate control or the
        queue dropped it."""
        with self._lock:
            return self._core.offer(payload,
                                    self._clock() if generated_at is None else generated_at)

    @property
    def polls(self) -> int:
        """Polls answered so far."""
        return self._core.polls

    @property
    def offered(self) -> int:
        """Updates offered so far (taken or dropped by the queue)."""
        return self._core.offered

    def _on_query(self, query: zenoh.Query) -> None:
        with query:
            received_at = self._clock()
            payload = query.payload
            data = b"" if payload is None else payload.to_bytes()
            with self._lock:
                if self._sample is not None:
                    self._core.offer(self._sample(), received_at)
                try:
                    reply = self._core.on_poll(data, received_at, self._clock())
                except WireError as exc:
                    self.bad_input.report(str(query.key_expr), str(exc))
                    return
            query.reply(self._key, reply)

    def close(self) -> None:
        """Leave the swarm: the token goes first so the leader stops polling."""
        undeclare(self._token)
        self._control.close()
        undeclare(self._queryable)

    def __enter__(self) -> FollowerNode:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
