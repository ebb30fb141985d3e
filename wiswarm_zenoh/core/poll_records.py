"""A poll's life in the leader, in one record with named stages (as h11's ``_state``).

A poll is ``SENT`` until a valid reply or its deadline ends it. A valid reply makes it
``ANSWERED``: the poll is over for the scheduler, and what taking the reply involves (its
outcome in p and the timeout, the clock sample, reassembly) waits. If the reply completed
an update, the poll is then ``UNSETTLED``: the update counts for the scheduler's ages, and
its checksum, AoI and delivery wait. Then it is ``DONE`` and forgotten. At most one poll is
``SENT``; answered ones wait in arrival order, and their work is done in that order.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

from wiswarm_zenoh.core.peers import Peer
from wiswarm_zenoh.core.wire import FragmentData, Reply, encode_control_packed

__all__ = ["Pick", "PollLife", "PollRequest", "Stage"]


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
        """The control message to broadcast with this poll, encoded now."""
        return encode_control_packed(self.control_seq, self.sent_at, self.packed_entries,
                                     self.epoch)


class Stage(Enum):
    SENT = "sent"  # out: a valid reply or the deadline ends it
    ANSWERED = "answered"  # over: its outcome, clock sample and fragment wait
    UNSETTLED = "unsettled"  # a whole update: its checksum, AoI and delivery wait
    DONE = "done"  # nothing left: forgotten


@dataclass(slots=True)
class PollLife:
    """One poll from sending to done. ``reply`` and ``answered_at`` are set when it is
    answered; ``frag``, ``whole`` and ``generated_at`` (leader clock, as estimated when
    the reply came) when it completed an update."""

    request: PollRequest
    peer: Peer
    stage: Stage = Stage.SENT
    reply: Reply | None = None
    answered_at: float = 0.0
    frag: FragmentData | None = None
    whole: bytes = b""
    generated_at: float = 0.0


@dataclass(slots=True)
class Pick:
    """Whom to poll after the poll ``poll_seq`` (in flight when picked) if its reply
    comes as usual: the follower at ``choice`` in the table, whose policy index at
    ``at`` (the reply's expected time) is ``value``."""

    poll_seq: int
    at: float
    choice: int
    value: float
    index: Callable[[float, float, float], float]  # the policy's
