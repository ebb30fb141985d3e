"""What the leader declares per follower: a querier for polls, publishers for stats and
fresh updates. Declared at join, so a poll costs no key or route set-up.

The querier's own timeout is the ceiling (``--timeout``), not the follower's adaptive
timeout: the core's timer ends the poll at the adaptive deadline, and the get stays open
until the ceiling, so a reply that comes after that deadline still reaches the core and
teaches it the link is slower than measured (``core.poll_timing``). Replies go to the
callback given with each poll, on Zenoh's own thread (``indirect=False``): the leader's
loop then waits on one inbox for every poll's replies, late ones included. Zenoh drops a
get's callback when the get is over (no queryable matched, every replier sent its
final, or the ceiling passed): that drop is the poll's end, reported with its sequence
number (``on_end``), so a poll nobody can answer ends at once, not at its timer."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any, cast

import zenoh

from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

ZENOH_TIMEOUT = b"Timeout"


def _set_matching(link: FollowerLink, flag: str, status: zenoh.MatchingStatus) -> None:
    setattr(link, flag, status.matching)  # the error reply Zenoh itself gives a get that timed out


@dataclass
class FollowerLink:
    follower: str
    key: str
    session: zenoh.Session
    stats: zenoh.Publisher
    fresh: zenoh.Publisher
    listening: bool = False  # some subscriber matches ``fresh``
    stats_listening: bool = False  # some subscriber matches ``stats``
    errors: int = 0  # replies refused here, before the core (error replies, oversized)
    _listeners: list[zenoh.MatchingListener[None]] = field(default_factory=list, repr=False)
    querier: zenoh.Querier | None = field(default=None, repr=False)
    _on_reply: Callable[[zenoh.Reply], object] | None = field(default=None, repr=False)
    _on_end: Callable[[FollowerLink, int], object] | None = field(default=None, repr=False)

    @classmethod
    def open(cls, session: zenoh.Session, keys: SwarmKeys, follower: str, ceiling: float,
             on_reply: Callable[[FollowerLink, zenoh.Reply], object],
             on_end: Callable[[FollowerLink, int], object]) -> FollowerLink:
        """Declare what polling ``follower`` needs; its gets end after ``ceiling`` s at
        the latest, bring their replies to ``on_reply`` and their end (with the poll's
        sequence number) to ``on_end``."""
        key = keys.update(follower)
        link = cls(
            follower=follower,
            key=key,
            session=session,
            stats=session.declare_publisher(
                keys.stats(follower), encoding=zenoh.Encoding.APPLICATION_JSON
            ),
            fresh=session.declare_publisher(keys.fresh(follower)),
            # ALL: a rogue queryable on the same key cannot hide the real follower.
            # NONE: every reply is kept, not only the latest per key.
            querier=session.declare_querier(
                key, target=zenoh.QueryTarget.ALL,
                consolidation=zenoh.ConsolidationMode.NONE, timeout=ceiling),
        )
        link._on_reply = partial(on_reply, link)
        link._on_end = on_end
        # On Zenoh's own thread (a flag set, nothing more): the status is current at once,
        # with no thread kept per follower for it. Stats and fresh updates are made only
        # while someone listens (a subscriber already there counts at once: the
        # listener's first call comes later, from another thread).
        for publisher, flag in ((link.fresh, "listening"), (link.stats, "stats_listening")):
            link._listeners.append(publisher.declare_matching_listener(
                zenoh.handlers.Callback(partial(_set_matching, link, flag), indirect=False)))
            # (The stubs say this property is a bool; eclipse-zenoh 1.10 returns a
            # MatchingStatus: read untyped, or the mypyc-compiled build checks it for a
            # bool and raises.)
            status: zenoh.MatchingStatus = cast(Any, publisher).matching_status
            setattr(link, flag, status.matching)
        return link

    def poll(self, payload: bytes, poll_seq: int) -> None:
        """Send poll ``poll_seq``: its replies and its end go to ``on_reply`` and
        ``on_end`` (see ``open``), on Zenoh's thread."""
        assert self.querier is not None and self._on_reply is not None \
            and self._on_end is not None, "polled after close()"
        handler = zenoh.handlers.Callback(self._on_reply, partial(self._on_end, self, poll_seq),
                                          indirect=False)
        self.querier.get(handler, payload=payload)

    def poll_steady(self, payload: bytes,
                    token: zenoh.CancellationToken) -> zenoh.Handler[zenoh.Reply]:
        """Send a steady poll (``steady_gets``): its replies come through the channel
        returned, read by the poll thread; ``token`` ends the get early."""
        assert self.querier is not None, "polled after close()"
        return self.querier.get(payload=payload, cancellation_token=token)

    def payload(self, reply: zenoh.Reply, limit: int, bad_input: BadInputLog) -> bytes | None:
        """A reply's bytes, or None for an error reply or one over ``limit`` bytes (counted
        and logged; Zenoh's own timeout at the ceiling is no error: the core's timer has
        counted that poll unanswered long before)."""
        sample = reply.ok
        if sample is None:
            reason = b"" if reply.err is None else reply.err.payload.to_bytes()[:80]
            if reason != ZENOH_TIMEOUT:
                self.errors += 1
                bad_input.report(self.key, f"error reply {reason!r}")
            return None
        data = sample.payload.to_bytes()  # Zenoh holds it whole already: copy, then judge
        if len(data) > limit:
            self.errors += 1
            bad_input.report(self.key, f"reply of {len(data)} bytes exceeds the limit")
            return None
        return data

    def close(self) -> None:
        undeclare(*self._listeners)
        self._listeners.clear()
        if self.querier is not None:
            undeclare(self.querier)
            self.querier = None
        undeclare(self.fresh, self.stats)
