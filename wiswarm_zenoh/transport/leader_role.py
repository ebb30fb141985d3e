"""Which of a swarm's leaders polls (``election``), and what one that takes over starts
from (``standby``): the epoch the core's rule gives over every epoch heard, and the
weights and control the leader before it left."""

from __future__ import annotations

import logging
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.core import Leader
from wiswarm_zenoh.transport.election import Election
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.notify import notify
from wiswarm_zenoh.transport.standby import Handover
from wiswarm_zenoh.units import format_epoch

log = logging.getLogger("wiswarm_zenoh.transport.leader_node")


class LeaderRole:
    """This leader's role among its swarm's leaders, kept on the poll thread."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys, name: str, leader: Leader,
                 wake: Callable[[], None], on_role: Callable[[bool], None] | None) -> None:
        self.name = name
        self._on_role = on_role
        self._leader = leader
        self.active: bool | None = None  # this process polls (None: not decided yet)
        self._handover = Handover(session, keys)
        self._handover.own_epoch = leader.epoch
        self._election = Election(session, keys, name, leader.epoch, wake)

    @property
    def changed(self) -> bool:
        """The election's verdict differs from the role taken."""
        return self._election.leading != self.active

    def take(self, now: float) -> None:
        """Take the role the election gives: active (with an epoch above any heard, and
        the weights and control the leader before left) or standing by; ``on_role``
        hears it."""
        self.active = self._election.leading
        if not self.active:
            log.info("leader %s stands by (an older leader is active: %s)", self.name,
                     self._election.active[1])
        else:
            self._rise(now, take_state=True)
            log.info("leader %s is active, epoch %s", self.name,
                     format_epoch(self._leader.epoch))
        if self._on_role is not None:
            notify(self._on_role, self.active)

    def hold(self, now: float) -> None:
        """An active leader that hears an epoch as high as its own (two active across a
        partition) rises above it; a standby makes sure the leader it stands by for is
        still there."""
        if self.active and self._handover.epoch >= self._leader.epoch:
            self._rise(now, take_state=False)
        elif not self.active:
            self._election.recheck()

    def _rise(self, now: float, take_state: bool) -> None:
        heard, weights, control = self._handover.state()
        self._handover.own_epoch = self._leader.rise_above(
            heard, now, weights if take_state else None, control if take_state else None)

    def close(self) -> None:
        self._election.close()  # a standby takes over now
        self._handover.close()
