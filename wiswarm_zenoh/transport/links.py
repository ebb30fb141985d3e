"""What the leader declares per follower: a querier for polls, publishers for stats and
fresh updates. Declared once at join, so a poll costs no key or route set-up."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import cast

import zenoh

from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys


@dataclass
class FollowerLink:
    follower: str
    key: str
    querier: zenoh.Querier
    stats: zenoh.Publisher
    fresh: zenoh.Publisher
    listening: bool = False  # some subscriber matches ``fresh``
    _listener: zenoh.MatchingListener[None] | None = field(default=None, repr=False)

    @classmethod
    def open(cls, session: zenoh.Session, keys: SwarmKeys, follower: str,
             timeout: float) -> FollowerLink:
        key = keys.update(follower)
        link = cls(
            follower=follower,
            key=key,
            # ALL: a rogue queryable on the same key cannot hide the real follower.
            # NONE: every reply is kept, not only the latest per key.
            querier=session.declare_querier(
                key, target=zenoh.QueryTarget.ALL,
                consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout,
            ),
            stats=session.declare_publisher(
                keys.stats(follower), encoding=zenoh.Encoding.APPLICATION_JSON
            ),
            fresh=session.declare_publisher(keys.fresh(follower)),
        )
        # On Zenoh's own thread (a flag set, nothing more): the status is current at once,
        # with no thread kept per follower for it.
        link._listener = link.fresh.declare_matching_listener(
            zenoh.handlers.Callback(link._on_matching, indirect=False)
        )
        # A subscriber already there counts from the first delivery on: the listener's
        # first call comes later, from another thread. (The stubs say this property is a
        # bool; eclipse-zenoh 1.10 returns a MatchingStatus.)
        status = cast(zenoh.MatchingStatus, link.fresh.matching_status)
        link.listening = status.matching
        return link

    def _on_matching(self, status: zenoh.MatchingStatus) -> None:
        self.listening = status.matching

    def close(self) -> None:
        if self._listener is not None:
            undeclare(self._listener)
        undeclare(self.fresh, self.stats, self.querier)
