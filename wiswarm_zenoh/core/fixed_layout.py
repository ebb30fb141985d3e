"""One fixed byte layout for the two messages of every poll: the poll and the reply.

Each field has a single width (uint64, float64, uint32), so encoding is one ``struct``
call and decoding one ``struct`` call and a tuple comparison, instead of a general
msgpack walk, a dict and a dozen type checks: on a small machine where both ends of a
poll wake cold, that general path was a large share of each poll (see
``benchmarks/bench_poll.py``). The bytes are ordinary msgpack (valid, if not the
shortest, encoding), so any msgpack reader decodes them.

The unpackers return None for anything that is not exactly this layout, or that breaks a
rule of its message (its checker in ``messages``, which the strict decoder applies too).
The caller then runs the strict general decoder (``wire``), which accepts any other valid
encoding (a follower written in another language) or says what is wrong.
"""

from __future__ import annotations

import struct
from collections.abc import Callable

import msgpack

from wiswarm_zenoh.core.messages import (
    ID_BYTES,
    VERSION,
    WANTS,
    FragmentData,
    Poll,
    Reply,
    Want,
    id_fits,
    poll_fault,
    reply_fault,
)

__all__ = ["pack_poll", "pack_reply", "reply_prefix", "unpack_poll", "unpack_reply"]

UINT64, FLOAT64, UINT32, BIN32, NIL = b"\xcf", b"\xcb", b"\xce", b"\xc6", b"\xc0"
_key: Callable[[str], bytes] = msgpack.packb


# A struct and the constants it holds.
Layout = tuple[struct.Struct, tuple[bytes, ...]]


def _layout(*parts: bytes | str) -> Layout:
    """A struct over constant byte strings (``bytes``: a key, a type tag) alternating with
    typed values (``str`` codes), and its constants. Its unpacked fields are then the
    constants at even places (``fields[::2]``, one slice to compare) and values at odd."""
    assert all(isinstance(p, bytes) == (i % 2 == 0) for i, p in enumerate(parts))
    fmt = ">" + "".join(f"{len(p)}s" if isinstance(p, bytes) else p for p in parts)
    return struct.Struct(fmt), tuple(p for p in parts if isinstance(p, bytes))


# --- the poll: {v, t, seq, lt, e, want, ack}; four shapes (want x ack or not), four sizes ---

_POLL_HEAD = b"\x87" + _key("v") + bytes([VERSION]) + _key("t") + _key("poll") + _key("seq")


def _poll_layout(want: Want, with_ack: bool) -> Layout:
    tail = _key("want") + _key(want) + _key("ack")
    head = (_POLL_HEAD + UINT64, "Q", _key("lt") + FLOAT64, "d", _key("e") + UINT64, "Q")
    if not with_ack:
        return _layout(*head, tail + NIL)
    return _layout(*head, tail + b"\x92" + UINT64, "Q", UINT32, "I")


_POLL_SHAPES = {(want, with_ack): _poll_layout(want, with_ack)
                for want in WANTS for with_ack in (False, True)}
_POLL_BY_SIZE = {layout.size: (layout, constants, want, with_ack)
                 for (want, with_ack), (layout, constants) in _POLL_SHAPES.items()}
assert len(_POLL_BY_SIZE) == len(_POLL_SHAPES), "poll shapes must differ in size"


def pack_poll(poll: Poll) -> bytes:
    """``poll`` in its fixed layout (the leader sends no other)."""
    layout, constants = _POLL_SHAPES[poll.want, poll.ack is not None]
    head, lt_key, epoch_key, tail = constants[:4]
    if poll.ack is None:
        return layout.pack(head, poll.seq, lt_key, poll.leader_time, epoch_key, poll.epoch, tail)
    return layout.pack(head, poll.seq, lt_key, poll.leader_time, epoch_key, poll.epoch, tail,
                       poll.ack[0], UINT32, poll.ack[1])


def unpack_poll(data: bytes) -> Poll | None:
    """The poll in ``data`` if it is in this layout and valid, else None."""
    shape = _POLL_BY_SIZE.get(len(data))
    if shape is None:
        return None
    layout, constants, want, with_ack = shape
    fields = layout.unpack(data)
    if fields[::2] != constants:
        return None
    poll = Poll(fields[1], fields[3], (fields[7], fields[9]) if with_ack else None, want,
                fields[5])
    return poll if poll_fault(poll) is None else None


# --- the reply: {v, t, from, poll, rt, st, frag}; the id's length varies, then fixed ---

_REPLY_HEAD = b"\x87" + _key("v") + bytes([VERSION]) + _key("t") + _key("reply") + _key("from")
_AFTER_ID = (_key("poll") + UINT64, "Q", _key("rt") + FLOAT64, "d", _key("st") + FLOAT64, "d")
_NOTHING, _NOTHING_CONSTANTS = _layout(*_AFTER_ID, _key("frag") + NIL)
_FRAGMENT_PARTS = (
    *_AFTER_ID, _key("frag") + b"\x87" + _key("u") + UINT64, "Q", _key("g") + FLOAT64, "d",
    _key("i") + UINT32, "I", _key("n") + UINT32, "I", _key("size") + UINT64, "Q",
    _key("crc") + UINT32, "I", _key("data") + BIN32, "I",
)
_FRAGMENT, _FRAGMENT_CONSTANTS = _layout(*_FRAGMENT_PARTS)
# Its values only, the constants skipped unread (``peek_update``)
_FRAGMENT_VALUES = struct.Struct(">" + "".join(
    f"{len(part)}x" if isinstance(part, bytes) else part for part in _FRAGMENT_PARTS))


def reply_prefix(follower: str) -> bytes:
    """The bytes every reply of ``follower`` starts with (made once per follower)."""
    return _REPLY_HEAD + _key(follower)


def pack_reply(prefix: bytes, poll_seq: int, received_at: float, sent_at: float,
               frag: FragmentData | None) -> bytes:
    """A reply from the follower whose ``reply_prefix`` is ``prefix``."""
    c = _FRAGMENT_CONSTANTS
    if frag is None:
        return prefix + _NOTHING.pack(c[0], poll_seq, c[1], received_at, c[2], sent_at,
                                      _NOTHING_CONSTANTS[3])
    data = frag.data
    head = _FRAGMENT.pack(
        c[0], poll_seq, c[1], received_at, c[2], sent_at, c[3], frag.update_seq,
        c[4], frag.generated_at, c[5], frag.index, c[6], frag.count, c[7], frag.total_size,
        c[8], frag.checksum, c[9], len(data),
    )
    return b"".join((prefix, head, data))


def peek_update(data: bytes, follower: str) -> tuple[int, float, int] | None:
    """Of a reply from ``follower`` in this layout with a fragment: the poll it answers,
    its update's generation time (the follower's clock) and its count of fragments, read
    with nothing else checked (a guess until ``unpack_reply`` judges it: read where
    the next poll waits on it); None for any other reply."""
    expected = expect(follower)
    if expected is None:
        return None
    prefix = expected[1]
    if len(data) < len(prefix) + _FRAGMENT.size or not data.startswith(prefix):
        return None
    values = _FRAGMENT_VALUES.unpack_from(data, len(prefix))
    return values[0], values[4], values[6]


def _sender(data: bytes) -> tuple[str, int] | None:
    """The follower id after the reply's head, if the wire allows it, and where it ends."""
    start = len(_REPLY_HEAD)
    if len(data) <= start + 1 or not data.startswith(_REPLY_HEAD):
        return None
    tag = data[start]
    if 0xA0 <= tag <= 0xBF:  # fixstr
        length, start = tag & 0x1F, start + 1
    elif tag == 0xD9:  # str8
        length, start = data[start + 1], start + 2
    else:
        return None
    if length not in ID_BYTES:
        return None
    try:
        return data[start:start + length].decode("utf-8"), start + length
    except UnicodeDecodeError:
        return None


# The follower a reply is expected from, and its ``reply_prefix``: its id then need not
# be parsed (the leader knows whom it polled; a reply from anyone else is parsed in full).
# Kept here by id for a swarm's followers (at most _EXPECTED_KEPT; others are made anew);
# the key type admits None so that a reply read for no follower needs no test first.
Expected = tuple[str, bytes]
_EXPECTED_KEPT = 4096
_expected: dict[str | None, Expected] = {}


def expect(follower: str) -> Expected | None:
    """What ``unpack_reply`` may expect of ``follower``, if its id is one the wire allows."""
    expected = _expected.get(follower)
    if expected is None and id_fits(follower):
        expected = (follower, reply_prefix(follower))
        if len(_expected) < _EXPECTED_KEPT:
            _expected[follower] = expected
    return expected


def unpack_reply(data: bytes, follower: str | None = None) -> Reply | None:
    """The reply in ``data`` if it is in this layout and valid, else None; read faster if
    it is from ``follower`` (whom the caller polled, if it knows)."""
    expected = _expected.get(follower)  # not through expect(): this runs on every reply
    if expected is None and follower is not None:
        expected = expect(follower)
    if expected is not None and data.startswith(expected[1]):
        follower, at = expected[0], len(expected[1])
    else:
        sender = _sender(data)
        if sender is None:
            return None
        follower, at = sender
    rest = len(data) - at
    if rest == _NOTHING.size:
        fields = _NOTHING.unpack_from(data, at)
        if fields[::2] != _NOTHING_CONSTANTS:
            return None
        reply = Reply(follower, fields[1], fields[3], fields[5], None)
    else:
        if rest < _FRAGMENT.size:
            return None
        fields = _FRAGMENT.unpack_from(data, at)
        seq, rt, st, update_seq, generated_at, index, count, total, crc, length = fields[1::2]
        if fields[::2] != _FRAGMENT_CONSTANTS or length != rest - _FRAGMENT.size:
            return None
        reply = Reply(follower, seq, rt, st, FragmentData(
            update_seq, generated_at, index, count, total, crc, data[at + _FRAGMENT.size:]))
    return reply if reply_fault(reply) is None else None
