"""The wire messages as values, and the limits every codec of them enforces."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

VERSION = 2  # 2: polls and control carry the leader's epoch
MAX_ID_BYTES = 128  # UTF-8
MAX_WAYPOINTS = 256
MAX_CONTROL_ENTRIES = 100_000
UINT32 = 0xFFFFFFFF
MAX_INT = 2**63 - 1
MAX_SIZE = 2**40  # bytes of one update, as the wire allows (configs set tighter limits)

Waypoint = tuple[float, float, float, float]  # (t, x, y, z)
Want = Literal["next", "fresh"]


# Poll, FragmentData and Reply are built on every poll: not frozen, since a frozen
# dataclass costs several times more to build (each field through object.__setattr__).
@dataclass(slots=True)
class Poll:
    """The leader's request: which poll this is, when it left, and what arrived last."""

    seq: int
    leader_time: float
    ack: tuple[int, int] | None  # (update seq, fragment index) last received from this follower
    want: Want = "next"
    epoch: int = 0  # which leader (a restarted or new leader has a larger one)


@dataclass(slots=True)
class FragmentData:
    """One piece of one update, with what the leader needs to check the whole."""

    update_seq: int
    generated_at: float  # follower clock
    index: int
    count: int
    total_size: int
    checksum: int  # CRC-32 of the whole update
    data: bytes


@dataclass(slots=True)
class Reply:
    """A follower's answer to one poll; ``fragment`` is None for "nothing new"."""

    follower: str
    poll_seq: int
    received_at: float  # follower clock, when the poll arrived
    sent_at: float  # follower clock, when this reply left
    fragment: FragmentData | None


@dataclass(frozen=True, slots=True)
class Control:
    """Latest control information for every follower, broadcast with each poll."""

    seq: int
    leader_time: float
    entries: Mapping[str, Sequence[Waypoint]]
    epoch: int = 0  # the leader's, as in its polls


def id_fits(value: object) -> bool:
    """A follower id the wire carries: a non-empty string of at most MAX_ID_BYTES in UTF-8."""
    return isinstance(value, str) and 0 < len(value.encode("utf-8", "replace")) <= MAX_ID_BYTES
