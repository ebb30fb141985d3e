"""Which followers a leader has, from their liveliness tokens, and a link to each.

A token's coming and going is queued on Zenoh's thread and applied on the poll thread
(``apply``), so the core changes only there. A follower whose token goes is polled no
more, but its link stays open for ``forget_after`` seconds so that its stats go on, its
age growing (``present`` false): a site cut off upstream is not reported fresh. Back
within that time it is taken up where it was; after it, forgotten.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.core import Leader
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.edge import site_of
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.links import FollowerLink

log = logging.getLogger(__name__)

FORGET_AFTER = 60.0  # seconds a follower that left stays in the stats, its age growing

ReplyHandler = Callable[[FollowerLink, zenoh.Reply], object]
EndHandler = Callable[[FollowerLink, int], object]  # a poll's get is over (its sequence)


class Membership:
    """The followers' links, kept in step with their tokens and with the core."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys, ceiling: float,
                 on_reply: ReplyHandler, on_end: EndHandler, wake: Callable[[], object],
                 bad_input: BadInputLog, forget_after: float = FORGET_AFTER) -> None:
        self._session, self._keys = session, keys
        self._ceiling, self._on_reply, self._on_end, self._wake = ceiling, on_reply, on_end, wake
        self._bad_input = bad_input
        self._forget_after = forget_after
        self.links: dict[str, FollowerLink] = {}
        self._changes: deque[tuple[str, bool]] = deque()  # (follower, joined), as they came
        self._departed_at: dict[str, float] = {}  # followers gone, not forgotten yet
        self._tokens = session.liveliness().declare_subscriber(keys.members, self._on_token,
                                                               history=True)

    @property
    def changed(self) -> bool:
        return bool(self._changes)

    def _on_token(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        follower = self._keys.follower_of(key, "members")
        if follower is None:
            self._bad_input.report(key, "not a valid member key")
            return
        self._changes.append((follower, sample.kind == zenoh.SampleKind.PUT))
        self._wake()

    def apply(self, leader: Leader, lock: threading.Lock, now: float) -> list[tuple[str, bool]]:
        """Take the tokens' changes into ``leader``; the joins and leaves that count
        (a second leave of a follower already gone does not)."""
        done = []
        while self._changes:
            follower, joined = self._changes.popleft()
            if joined:
                with lock:
                    leader.add_follower(follower, now, link=site_of(follower))
                self._departed_at.pop(follower, None)
                if follower not in self.links:
                    self.links[follower] = FollowerLink.open(
                        self._session, self._keys, follower, self._ceiling, self._on_reply,
                        self._on_end)
                log.info("follower %s joined", follower)
            elif follower in self.links and follower not in self._departed_at:
                with lock:
                    leader.remove_follower(follower, now)
                self._departed_at[follower] = now  # its link stays: its stats go on
                log.info("follower %s left (its liveliness token is gone): polled no "
                            "more; its stats show its age growing for %.0f s", follower,
                            self._forget_after)
            else:
                continue
            done.append((follower, joined))
        return done

    def forget_departed(self, leader: Leader, lock: threading.Lock, now: float) -> None:
        """Followers gone for ``forget_after`` are forgotten, their links closed."""
        for follower, left_at in list(self._departed_at.items()):
            if now - left_at >= self._forget_after:
                del self._departed_at[follower]
                with lock:
                    leader.forget_follower(follower)
                self.links.pop(follower).close()
                log.info("follower %s forgotten (gone for %.0f s)", follower, now - left_at)

    def close(self) -> None:
        undeclare(self._tokens)
        for link in self.links.values():
            link.close()
        self.links.clear()
