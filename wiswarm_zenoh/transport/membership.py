"""Which followers a leader has, from their liveliness tokens (found by ``discovery``,
which asks again for what Zenoh's first answer missed), and a link to each.

A token's coming and going is posted on Zenoh's thread, as a command to the poll
thread's inbox, and applied there, so the core changes only there. A follower whose
token goes and stays away ``LEAVE_GRACE`` (a router failover brings it back over the
other router within milliseconds: no leave, no join, its estimates as they were, and
probed at once if it fell silent meanwhile: its token says it is up) is
polled no more, but its link stays open for ``forget_after`` seconds so
that its stats go on, its age growing (``present`` false): a site cut off upstream is
not reported fresh. Back within that time it is taken up where it was; after it,
forgotten.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from functools import partial

import zenoh

from wiswarm_zenoh.core import Leader
from wiswarm_zenoh.core.members import site_of
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.discovery import Discovery
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.links import FollowerLink
from wiswarm_zenoh.transport.notify import notify

log = logging.getLogger(__name__)

FORGET_AFTER = 60.0  # seconds a follower that left stays in the stats, its age growing
LEAVE_GRACE = 0.25  # seconds a token must stay away to count as a leave (a router
# failover takes a token away and brings it back over the other router within ms)

ReplyHandler = Callable[[FollowerLink, zenoh.Reply], None]
EndHandler = Callable[[FollowerLink, int], None]  # a poll's get is over (its sequence)


class Membership:
    """The followers' links, kept in step with their tokens and with the core."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys, leader: Leader,
                 clock: Callable[[], float], post: Callable[[Callable[[], object]], object],
                 on_reply: ReplyHandler, on_end: EndHandler, bad_input: BadInputLog,
                 forget_after: float = FORGET_AFTER,
                 on_join: Callable[[str], object] | None = None,
                 on_leave: Callable[[str], object] | None = None) -> None:
        self._session, self._keys, self._leader, self._clock = session, keys, leader, clock
        # Replies and ends come on Zenoh's thread: handled on the poll thread.
        self._post = post
        self._on_reply: Callable[[FollowerLink, zenoh.Reply], object] = \
            lambda link, reply: post(partial(on_reply, link, reply))
        self._on_end: Callable[[FollowerLink, int], object] = \
            lambda link, poll_seq: post(partial(on_end, link, poll_seq))
        self._bad_input = bad_input
        self._forget_after = forget_after
        self.links: dict[str, FollowerLink] = {}
        self.followers: list[str] = []  # those polled (a copy: read from any thread)
        self._on_join, self._on_leave = on_join, on_leave
        self._departed_at: dict[str, float] = {}  # followers gone, not forgotten yet
        self._expected: set[str] = set()  # there by another sign, their token not seen
        self._leaving: dict[str, threading.Timer] = {}  # tokens gone lately (the grace)
        self._leaving_lock = threading.Lock()
        # Asked again faster while a follower that left is still in the stats: its
        # return is awaited.
        self.discovery = Discovery(session, keys.members, self._on_token, "follower token",
                                   expecting=self._awaiting)

    def expect(self, follower: str) -> None:
        """``follower`` is there by another sign than its token (its ROS 2 source token,
        say): asked for faster until it joins. (Any thread.)"""
        if follower not in self.followers:
            self._expected.add(follower)

    def _awaiting(self) -> bool:
        self._expected.difference_update(self.followers)
        return bool(self._departed_at or self._expected)

    def _on_token(self, key: str, joined: bool) -> None:
        follower = self._keys.follower_of(key, "members")
        if follower is None:
            self._bad_input.report(key, "not a valid member key")
            return
        with self._leaving_lock:
            leaving = self._leaving.pop(follower, None)
            if leaving is not None:
                leaving.cancel()
                if joined:  # back within the grace: it never left (a router failover)
                    log.info("follower %s's token went and came back within %.0f ms (a "
                             "router failover?): still a member", follower, LEAVE_GRACE * 1e3)
                    self._post(partial(self._leader.follower_reachable, follower))
                    return
            if not joined:
                timer = threading.Timer(LEAVE_GRACE, self._left, (follower,))
                timer.daemon = True
                self._leaving[follower] = timer
                timer.start()
                return
        self._post(partial(self._change, follower, True))

    def _left(self, follower: str) -> None:
        """Its token stayed away for the grace: it left."""
        with self._leaving_lock:
            if self._leaving.pop(follower, None) is None:
                return  # it came back meanwhile
        self._post(partial(self._change, follower, False))

    def _change(self, follower: str, joined: bool) -> None:
        """A token's change, on the poll thread, into the core; the application hears
        of the joins and leaves that count (a second leave of one gone does not)."""
        now = self._clock()
        if joined:
            self._leader.add_follower(follower, now, link=site_of(follower))
            self._departed_at.pop(follower, None)
            if follower not in self.links:
                self.links[follower] = FollowerLink.open(
                    self._session, self._keys, follower, self._leader.config.timeout,
                    self._on_reply, self._on_end)
            log.info("follower %s joined", follower)
        elif follower in self.links and follower not in self._departed_at:
            self._leader.remove_follower(follower, now)
            self._departed_at[follower] = now  # its link stays: its stats go on
            log.info("follower %s left (its liveliness token is gone): polled no "
                     "more; its stats show its age growing for %.0f s", follower,
                     self._forget_after)
        else:
            return
        self.followers = self._leader.followers  # before the callback: it may call in
        callback = self._on_join if joined else self._on_leave
        if callback is not None:
            notify(callback, follower)

    def forget_departed(self, now: float) -> None:
        """Followers gone for ``forget_after`` are forgotten, their links closed."""
        for follower, left_at in list(self._departed_at.items()):
            if now - left_at >= self._forget_after:
                del self._departed_at[follower]
                self._leader.forget_follower(follower)
                self.links.pop(follower).close()
                log.info("follower %s forgotten (gone for %.0f s)", follower, now - left_at)

    def close(self) -> None:
        self.discovery.close()
        with self._leaving_lock:
            for timer in self._leaving.values():
                timer.cancel()
            self._leaving.clear()
        for link in self.links.values():
            link.close()
        self.links.clear()
