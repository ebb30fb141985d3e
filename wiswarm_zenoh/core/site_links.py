"""Followers behind one link share its reliability: the (site, follower) pairs a cloud
leader polls through an edge leader. Every poll of a site crosses the same wide-area
link and the edge answers from what it holds, so a lost link is the site's, not one
follower's: with one estimate per site, p falls within W polls of the site, not W polls
of each of its followers, and the site's other followers are not polled into it."""

from __future__ import annotations

from wiswarm_zenoh.core.estimators import ReliabilityEstimator
from wiswarm_zenoh.core.events import Answering, Event, Silent
from wiswarm_zenoh.core.peers import Peer, PeerTable


class SiteLinks:
    """Which followers share a link, and the one estimator each link has."""

    def __init__(self) -> None:
        self._estimators: dict[str, ReliabilityEstimator] = {}
        self._members: dict[str, list[str]] = {}
        self.link_of: dict[str, str] = {}  # each follower's link, if it has one

    def attach(self, follower: str, peer: Peer, link: str) -> None:
        """``follower`` is reached over ``link``: its peer takes the link's estimator
        (the first follower's own, for a new link)."""
        peer.share_reliability(self._estimators.setdefault(link, peer.reliability))
        self._members.setdefault(link, []).append(follower)
        self.link_of[follower] = link

    def detach(self, follower: str) -> None:
        link = self.link_of.pop(follower, None)
        if link is None:
            return
        members = self._members[link]
        members.remove(follower)
        if not members:
            del self._members[link], self._estimators[link]

    def siblings(self, follower: str) -> list[str]:
        """The other followers behind ``follower``'s link (none without a link)."""
        link = self.link_of.get(follower)
        return [] if link is None else [m for m in self._members[link] if m != follower]

    def shared_change(self, polled: str, before: float, table: PeerTable, window: int,
                      now: float) -> list[Event]:
        """The p that ``polled`` shares went from ``before`` with its poll: the others
        behind its link take it into the policy's columns, and say when they fall
        silent or answer again with it."""
        events: list[Event] = []
        for follower in self.siblings(polled):
            peer = table.peers[follower]
            if peer.silent and before > 0.0:
                peer.silent_since = now
                events.append(Silent(follower, window))
            elif not peer.silent and before <= 0.0:
                events.append(Answering(follower, now - peer.silent_since))
            peer.reliability_moved()
        return events
