"""The records of a poll in the leader: the request a shell sends, the leader's own
record of it while it is out, and the pick made for after it."""

from __future__ import annotations

import math
from dataclasses import dataclass

from wiswarm_zenoh.core.peer import Peer
from wiswarm_zenoh.core.policies import IndexPolicy
from wiswarm_zenoh.core.wire import encode_control_packed

__all__ = ["Flight", "Pick", "PollRequest"]


@dataclass(slots=True)
class PollRequest:
    """A poll to send: ``payload`` to the follower, and ``controls`` to broadcast
    alongside when the control information is due (``LeaderConfig.control_period``),
    a message per site (None: the followers of no site); None when it is not.

    ``steady``: it is the only poll out, to a follower that answered its polls in time
    so far; the shell may then wait on this request's own replies alone and end the
    request at its ``deadline`` (a later reply would only lengthen a timeout that has
    held). Any other request stays open past its deadline, so that a late reply still
    teaches (``poll_timing``).

    The control message is encoded when asked for, once per request. (Not frozen, as
    the wire messages: one is made per poll.)
    """

    follower: str
    poll_seq: int
    payload: bytes
    deadline: float
    sent_at: float
    control_seq: int
    packed_entries: dict[str | None, bytes] | None  # by site, when control is due
    epoch: int
    steady: bool = False

    @property
    def controls(self) -> dict[str | None, bytes] | None:
        """The control messages to broadcast with this poll, by site, encoded now; None
        when none is due."""
        if self.packed_entries is None:
            return None
        return {site: encode_control_packed(self.control_seq, self.sent_at, packed,
                                            self.epoch)
                for site, packed in self.packed_entries.items()}

    @property
    def control(self) -> bytes | None:
        """The message for the followers of no site (a single swarm's, all of them); None
        when none is due or every follower is a site's."""
        packed = None if self.packed_entries is None else self.packed_entries.get(None)
        if packed is None:
            return None
        return encode_control_packed(self.control_seq, self.sent_at, packed, self.epoch)


@dataclass(slots=True)
class Flight:
    """A poll out, as the leader keeps it until a valid answer or its deadline ends it."""

    request: PollRequest
    peer: Peer
    refused: bool = False  # a reply to it was refused for its clock stamps


@dataclass(slots=True)
class Pick:
    """Whom to poll after the poll ``poll_seq`` of the follower at ``polled`` (in flight
    when picked) if its reply comes as usual: the follower at ``choice`` in the table,
    whose index under ``policy`` at ``at`` (the reply's expected time, in slots of
    ``slot``) is ``value``. It surely holds if the reply answers with an update generated
    at ``fresh_from`` or later on the follower's clock, ``holds_from`` on the leader's
    (+inf: not known ahead)."""

    poll_seq: int
    polled: int
    at: float
    slot: float
    choice: int
    value: float
    policy: IndexPolicy
    holds_from: float = math.inf
    fresh_from: float = math.inf
