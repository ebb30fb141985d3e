"""A lone poll held back for a phased source's next update (``sources.worth_waiting``):
nothing goes out until then, and once per poll (the pick made then is sent whatever its
phase)."""

from __future__ import annotations

import math

from wiswarm_zenoh.core.peers import PeerTable
from wiswarm_zenoh.core.sources import worth_waiting


class PollHold:
    """``until``: no poll before then (-inf: none is held); ``held``: a poll was held
    since the last one sent, so none is held again (the leader clears both as a poll
    goes out)."""

    def __init__(self) -> None:
        self.until = -math.inf
        self.held = False

    def holds(self, table: PeerTable, i: int, now: float) -> bool:
        """Whether the poll of the follower at ``i`` of ``table``, the only one to go
        out, is better sent when its phased source's next update is ready; then nothing
        goes out until ``until``."""
        pace = table.peers[table.ids[i]].pace
        if self.held or not pace.phased or pace.paced:
            return False
        wait = worth_waiting(now, table.tau[i], table.ready[i], table.interval[i],
                             table.w[i] * table.p[i], sum(table.w))
        if wait <= 0.0:
            return False
        self.held, self.until = True, now + wait
        return True
