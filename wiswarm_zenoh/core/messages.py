"""The wire messages as values, and the rules every codec of them enforces.

A field's wire type (an unsigned integer of 32 or 64 bits, a float64, a string, bytes)
is its codec's to read: the fixed layout's ``struct`` codes hold nothing else, and the
strict decoder checks each msgpack value. What the protocol asks beyond the types is
stated once per message, in its checker (``poll_fault``, ``reply_fault``,
``control_fault``), which both decoders apply to the values they read, so they cannot
disagree on what is valid. A checker returns what is wrong, naming the field by its wire
key, or None.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal, TypeGuard

VERSION = 2  # 2: polls and control carry the leader's epoch
MAX_ID_BYTES = 128  # UTF-8
MAX_WAYPOINTS = 256
"""The most waypoints one follower's control entry may carry."""
MAX_CONTROL_ENTRIES = 100_000
UINT32 = 2**32 - 1  # the widest unsigned integers on the wire
UINT64 = 2**64 - 1
MAX_INT = 2**63 - 1
MAX_SIZE = 2**40  # bytes of one update, as the wire allows (configs set tighter limits)

Waypoint = tuple[float, float, float, float]  # (t, x, y, z)
"""One waypoint ``(t, x, y, z)``: a time on the leader's clock (s) and a position (m)."""
Want = Literal["next", "fresh"]
WANTS: tuple[Want, ...] = ("next", "fresh")


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


ID_BYTES = range(1, MAX_ID_BYTES + 1)  # the length of a follower id in UTF-8
ID_RULE = f"a non-empty string of at most {MAX_ID_BYTES} bytes in UTF-8"


def id_fits(value: object) -> TypeGuard[str]:
    """A follower id the wire carries (``ID_RULE``)."""
    return isinstance(value, str) and len(value.encode("utf-8", "replace")) in ID_BYTES


def _above(key: str, value: object, limit: int) -> str:
    return f"field {key!r} must be at most {limit}, got {value!r}"


def _infinite(key: str, value: float) -> str:
    return f"field {key!r} must be finite, got {value!r}"


# The checkers run on every poll and reply, so each rule is one comparison (``x - x``
# is 0.0 for a finite float only, and cheaper than ``math.isfinite``).

def poll_fault(poll: Poll) -> str | None:
    """What in ``poll`` breaks the protocol, or None."""
    if poll.seq > MAX_INT:
        return _above("seq", poll.seq, MAX_INT)
    if poll.leader_time - poll.leader_time != 0.0:
        return _infinite("lt", poll.leader_time)
    if poll.ack is not None and poll.ack[0] > MAX_INT:
        return _above("ack[0]", poll.ack[0], MAX_INT)
    if poll.epoch > MAX_INT:
        return _above("e", poll.epoch, MAX_INT)
    return None


def reply_fault(reply: Reply) -> str | None:
    """What in ``reply`` breaks the protocol, or None. Its sender's id is not looked at:
    a reader checks it (``id_fits``) where it reads it, once per follower at best."""
    if reply.poll_seq > MAX_INT:
        return _above("poll", reply.poll_seq, MAX_INT)
    if reply.received_at - reply.received_at != 0.0:
        return _infinite("rt", reply.received_at)
    if reply.sent_at - reply.sent_at != 0.0:
        return _infinite("st", reply.sent_at)
    frag = reply.fragment
    if frag is None:
        return None
    if frag.update_seq > MAX_INT:
        return _above("frag.u", frag.update_seq, MAX_INT)
    if frag.generated_at - frag.generated_at != 0.0:
        return _infinite("frag.g", frag.generated_at)
    if not frag.index < frag.count:
        return f"field 'frag.i' must be below 'frag.n' ({frag.count}), got {frag.index}"
    if not len(frag.data) <= frag.total_size <= MAX_SIZE:  # the update holds its fragment
        return (f"field 'frag.size' must be in [{len(frag.data)} (its data), {MAX_SIZE}], "
                f"got {frag.total_size}")
    return None


def waypoints_fault(waypoints: Sequence[Sequence[float]]) -> str | None:
    """What is wrong with one follower's waypoints (from the wire or from the local
    application), or None: at most MAX_WAYPOINTS, each 4 finite numbers (t, x, y, z)."""
    if len(waypoints) > MAX_WAYPOINTS:
        return f"at most {MAX_WAYPOINTS} waypoints, got {len(waypoints)}"
    for wp in waypoints:
        if len(wp) != 4 or not all(math.isfinite(float(c)) for c in wp):
            return f"a waypoint must be 4 finite numbers (t, x, y, z), got {list(wp)!r}"
    return None


def control_fault(control: Control) -> str | None:
    """What in ``control`` breaks the protocol, or None."""
    if control.seq > MAX_INT:
        return _above("seq", control.seq, MAX_INT)
    if not math.isfinite(control.leader_time):
        return _infinite("lt", control.leader_time)
    if control.epoch > MAX_INT:
        return _above("e", control.epoch, MAX_INT)
    if len(control.entries) > MAX_CONTROL_ENTRIES:
        return f"field 'entries' holds at most {MAX_CONTROL_ENTRIES}, got {len(control.entries)}"
    for follower, waypoints in control.entries.items():
        if not id_fits(follower):
            return f"a control entry's key must be {ID_RULE}, got {follower!r}"
        fault = waypoints_fault(waypoints)
        if fault is not None:
            return f"control entry {follower!r}: {fault}"
    return None


def check_epoch(epoch: int) -> None:
    """A leader's epoch must fit the wire (ValueError otherwise)."""
    if type(epoch) is not int or not 0 <= epoch <= MAX_INT:
        raise ValueError(f"epoch must be an integer in [0, {MAX_INT}], got {epoch!r}")
