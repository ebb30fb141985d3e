"""The leader's book of members: who joins (and who comes back, taken up where it was),
who left and is still shown ageing until forgotten, and the weights an operator gives
members before they join (``wiswarm leader --weight``), which a member takes each time
it joins. Off the poll path: only membership and the operator change it."""

from __future__ import annotations

import math
from collections.abc import Mapping

from wiswarm_zenoh.core.config import LeaderConfig
from wiswarm_zenoh.core.peers import FollowerStats, Peer, PeerTable
from wiswarm_zenoh.core.site_links import SiteLinks


def check_weight(weight: float) -> float:
    """``weight`` if it is a number >= 0; ValueError saying why not."""
    if not (math.isfinite(weight) and weight >= 0.0):
        raise ValueError(f"a weight must be a number >= 0, got {weight!r}")
    return weight


class MemberBook:
    """The members of ``table`` (those polled), those that left (``departed``: polled no
    more, their age growing in ``stats``), and the weight ``presets``."""

    def __init__(self, config: LeaderConfig, table: PeerTable, site_links: SiteLinks) -> None:
        self._config, self._table, self._site_links = config, table, site_links
        self.departed: dict[str, Peer] = {}
        self.presets: dict[str, float] = {}
        self._joined: set[str] = set()  # every member that joined, ever

    def join(self, follower: str, now: float, link: str | None) -> None:
        """``follower`` joined, or rejoined after a restart (its transfer state is reset).
        One that left and comes back is taken up where it was; followers of one ``link``
        share its p. Its preset, if it has one, is its weight from now on."""
        peer = self._table.peers.get(follower)
        if peer is not None:
            peer.restart()
        else:
            back = self.departed.pop(follower, None)
            if back is not None:
                back.restart()
                back.left_at = None
            peer = back or Peer.new(follower, self._config, now, self._table.poll_times)
            if link is not None:
                self._site_links.attach(follower, peer, link)
            self._table.add(peer)
        self._joined.add(follower)
        preset = self.presets.get(follower)
        if preset is not None:
            peer.set_weight(preset)

    def leave(self, follower: str, now: float | None) -> bool:
        """``follower`` left at ``now``: out of the table, its record kept ageing; False
        if it was not a member."""
        peer = self._table.peers.get(follower)
        if peer is None:
            return False
        peer.left_at = now
        self._table.remove(follower)
        self._site_links.detach(follower)
        self.departed[follower] = peer
        return True

    def preset(self, follower: str, weight: float) -> None:
        """``follower``'s weight whenever it joins (again), and now if it is a member."""
        self.presets[follower] = check_weight(weight)
        peer = self._table.peers.get(follower)
        if peer is not None:
            peer.set_weight(weight)

    @property
    def never_joined(self) -> list[str]:
        """Members given a preset that have not joined so far."""
        return [follower for follower in self.presets if follower not in self._joined]

    def take_weights(self, weights: Mapping[str, float]) -> None:
        """Weights of another leader's (a takeover): those of members it knows, if valid."""
        for follower, weight in weights.items():
            peer = self._table.peers.get(follower)
            if peer is not None and math.isfinite(weight) and weight >= 0.0:
                peer.set_weight(weight)

    def stats(self, follower: str, now: float, refused_before: int) -> FollowerStats:
        """A member's figures, or a departed one's (ageing); ValueError for neither."""
        departed = self.departed.get(follower)
        if departed is not None:
            return departed.stats(now, refused_before, present=False)
        return self.peer(follower).stats(now, refused_before)

    def peer(self, follower: str) -> Peer:
        """A member's record; ValueError for a follower not polled."""
        try:
            return self._table.peers[follower]
        except KeyError:
            raise ValueError(f"unknown follower {follower!r}") from None
