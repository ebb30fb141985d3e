"""What the leader keeps of one poll through its life: the request sent, the answer taken
on the fast path, the update whose checksum waits, the pick prepared for the next poll."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from wiswarm_zenoh.core.peers import Peer
from wiswarm_zenoh.core.wire import FragmentData, Reply, encode_control_packed

__all__ = ["Answered", "PollRequest", "Prepared", "Unsettled"]


@dataclass(slots=True)
class PollRequest:
    """A poll to send: ``payload`` to the follower, ``control`` broadcast alongside.

    The control message is encoded when asked for: a shell may repeat unchanged control
    less often than it polls, and then pays nothing for it on the other polls. (Not
    frozen, as the wire messages: one is made per poll.)
    """

    follower: str
    poll_seq: int
    payload: bytes
    deadline: float
    sent_at: float
    control_seq: int
    packed_entries: bytes
    epoch: int
    refused: bool = False  # a reply to it was refused for its clock stamps

    @property
    def control(self) -> bytes:
        return encode_control_packed(self.control_seq, self.sent_at, self.packed_entries,
                                     self.epoch)


@dataclass(slots=True)
class Unsettled:
    """A complete update already counted for the scheduler, whose checksum and delivery
    are ``settle``'s job. Its time-stamp is on the leader's clock as estimated when it
    came: a follower restarting in between changes nothing."""

    follower: str
    peer: Peer
    frag: FragmentData
    whole: bytes
    generated_at: float
    now: float


@dataclass(slots=True)
class Prepared:
    """``prepare``'s pick for the poll after the one in flight (``poll_seq``): the
    follower at ``choice`` in the table, whose policy index at ``at`` is ``value``."""

    poll_seq: int
    at: float
    choice: int
    value: float
    index: Callable[[float, float, float], float]  # the policy's


@dataclass(slots=True)
class Answered:
    """A valid reply that completed its poll on the fast path; the rest of taking it
    (the poll's outcome, clock, reassembly) waits for ``settle``."""

    flight: PollRequest
    peer: Peer
    reply: Reply
    now: float
