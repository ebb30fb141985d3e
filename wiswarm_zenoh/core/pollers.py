"""Who polls a follower: each poller's clock and transfer, and which one is the leader.

Anything that can reach a follower's key can poll it: a standby or restarted leader, a
stray ``get``, a rogue session. Each poller (told apart by the epoch in its polls) gets
its own transfer state, so fragments acknowledged by one never advance another's
transfer. One poller, the *main* one, consumes the queue: the highest epoch heard from
within ``expiry`` seconds (a restarted leader has a larger epoch). The others are
answered with the freshest update there is, without taking it from the main poller.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

from wiswarm_zenoh.core.fragments import OutgoingUpdate

MAX_POLLERS = 4  # transfers kept at once; the least recently heard other one is dropped


@dataclass(slots=True)
class Poller:
    """One poller as this follower knows it: its clock (the latest poll's leader time and
    when it came, on this follower's clock) and the update being sent to it."""

    epoch: int
    leader_time: float
    received_at: float
    sending: OutgoingUpdate | None = None
    last_seq: int = 0  # the last update started to this poller

    def leader_clock(self, now: float) -> float:
        """Its clock at ``now`` (this follower's clock), as its latest poll tells."""
        return self.leader_time + (now - self.received_at)


class Pollers:
    """The pollers heard recently, the main one first in line for the queue."""

    def __init__(self, expiry: float) -> None:
        self.expiry = expiry
        self.main: Poller | None = None
        self._by_epoch: OrderedDict[int, Poller] = OrderedDict()

    def get(self, epoch: int) -> Poller | None:
        return self._by_epoch.get(epoch)

    def heard(self, epoch: int, leader_time: float, received_at: float) -> Poller:
        """Record a poll; it makes its poller main if that one has the higher epoch or
        the main one went quiet. A new main takes over the update the old one was sending,
        from its first fragment (nothing the queue gave is lost)."""
        poller = self._by_epoch.get(epoch)
        if poller is None:
            poller = Poller(epoch, leader_time, received_at)
            self._by_epoch[epoch] = poller
            self._forget_beyond_limit()
        else:
            poller.leader_time, poller.received_at = leader_time, received_at
            self._by_epoch.move_to_end(epoch)
        main = self.main
        if main is None or (main is not poller and (
                epoch > main.epoch or received_at - main.received_at > self.expiry)):
            if main is not None and main.sending is not None and poller.sending is None:
                poller.sending = OutgoingUpdate(main.sending.update, main.sending.chunk)
                poller.last_seq = main.sending.update.seq
            self.main = poller
        return poller

    def _forget_beyond_limit(self) -> None:
        while len(self._by_epoch) > MAX_POLLERS:
            oldest = next(iter(self._by_epoch))
            if self._by_epoch[oldest] is self.main:
                self._by_epoch.move_to_end(oldest)
                oldest = next(iter(self._by_epoch))
            del self._by_epoch[oldest]
