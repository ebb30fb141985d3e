"""One fixed byte layout for the two messages of every poll: the poll and the reply.

Each field has a single width (uint64, float64, uint32), so encoding is one ``struct``
call and decoding one ``struct`` call and a tuple comparison, instead of a general
msgpack walk, a dict and a dozen type checks: on a small machine where both ends of a
poll wake cold, that general path was a large share of each poll (see
``benchmarks/bench_poll.py``). The bytes are ordinary msgpack (valid, if not the
shortest, encoding), so any msgpack reader decodes them.

The unpackers return None for anything that is not exactly this layout with every value
in range. The caller then runs the strict general decoder (``wire``), which accepts any
other valid encoding (a follower written in another language) or says what is wrong.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from operator import itemgetter
from typing import Any

import msgpack

from wiswarm_zenoh.core.messages import (
    MAX_ID_BYTES,
    MAX_INT,
    MAX_SIZE,
    VERSION,
    FragmentData,
    Poll,
    Reply,
    Want,
    id_fits,
)

__all__ = ["Expected", "expect", "pack_poll", "pack_reply", "reply_prefix", "unpack_poll",
           "unpack_reply"]

UINT64, FLOAT64, UINT32, BIN32, NIL = b"\xcf", b"\xcb", b"\xce", b"\xc6", b"\xc0"
WANTS: tuple[Want, ...] = ("next", "fresh")


def _key(name: str) -> bytes:
    packed: bytes = msgpack.packb(name)
    return packed


# A struct, the constants it holds, and what picks them out of its unpacked fields.
Layout = tuple[struct.Struct, tuple[bytes, ...], Callable[[tuple[Any, ...]], tuple[bytes, ...]]]


def _layout(*parts: bytes | str) -> Layout:
    """A struct over constant byte strings (``bytes``) and typed values (``str`` codes):
    the constants to pass when packing, and a getter that picks them out when unpacking."""
    fmt = ">" + "".join(f"{len(p)}s" if isinstance(p, bytes) else p for p in parts)
    constants = tuple(p for p in parts if isinstance(p, bytes))
    where = [i for i, p in enumerate(parts) if isinstance(p, bytes)]
    return struct.Struct(fmt), constants, itemgetter(*where)


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
_POLL_BY_SIZE = {shape[0].size: (key, *shape) for key, shape in _POLL_SHAPES.items()}
assert len(_POLL_BY_SIZE) == len(_POLL_SHAPES), "poll shapes must differ in size"


def pack_poll(poll: Poll) -> bytes:
    layout, constants, _ = _POLL_SHAPES[poll.want, poll.ack is not None]
    head, lt_key, epoch_key, tail = constants[:4]
    if poll.ack is None:
        return layout.pack(head, poll.seq, lt_key, poll.leader_time, epoch_key, poll.epoch, tail)
    return layout.pack(head, poll.seq, lt_key, poll.leader_time, epoch_key, poll.epoch, tail,
                       poll.ack[0], UINT32, poll.ack[1])


def unpack_poll(data: bytes) -> Poll | None:
    shape = _POLL_BY_SIZE.get(len(data))
    if shape is None:
        return None
    (want, with_ack), layout, constants, pick_constants = shape
    fields = layout.unpack(data)
    seq, lt, epoch = fields[1], fields[3], fields[5]
    if (pick_constants(fields) != constants or seq > MAX_INT or epoch > MAX_INT
            or lt - lt != 0.0):
        return None  # lt - lt is 0.0 for a finite float only
    if not with_ack:
        return Poll(seq, lt, None, want, epoch)
    acked = fields[7]
    return None if acked > MAX_INT else Poll(seq, lt, (acked, fields[9]), want, epoch)


# --- the reply: {v, t, from, poll, rt, st, frag}; the id's length varies, then fixed ---

_REPLY_HEAD = b"\x87" + _key("v") + bytes([VERSION]) + _key("t") + _key("reply") + _key("from")
_AFTER_ID = (_key("poll") + UINT64, "Q", _key("rt") + FLOAT64, "d", _key("st") + FLOAT64, "d")
_NOTHING, _NOTHING_CONSTANTS, _PICK_NOTHING = _layout(*_AFTER_ID, _key("frag") + NIL)
_FRAGMENT, _FRAGMENT_CONSTANTS, _PICK_FRAGMENT = _layout(
    *_AFTER_ID, _key("frag") + b"\x87" + _key("u") + UINT64, "Q", _key("g") + FLOAT64, "d",
    _key("i") + UINT32, "I", _key("n") + UINT32, "I", _key("size") + UINT64, "Q",
    _key("crc") + UINT32, "I", _key("data") + BIN32, "I",
)


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


def _sender(data: bytes) -> tuple[str, int] | None:
    """The follower id after the reply's head, and where it ends."""
    start = len(_REPLY_HEAD)
    if len(data) <= start + 1 or not data.startswith(_REPLY_HEAD):
        return None
    tag = data[start]
    if 0xA1 <= tag <= 0xBF:  # fixstr of 1..31 bytes
        length, start = tag & 0x1F, start + 1
    elif tag == 0xD9 and 0 < data[start + 1] <= MAX_ID_BYTES:  # str8
        length, start = data[start + 1], start + 2
    else:
        return None
    try:
        return data[start:start + length].decode("utf-8"), start + length
    except UnicodeDecodeError:
        return None


# The follower a reply is expected from, and its ``reply_prefix``: its id then need not
# be parsed (the leader knows whom it polled; a reply from anyone else is parsed in full).
Expected = tuple[str, bytes]


def expect(follower: str) -> Expected | None:
    """What ``unpack_reply`` may expect of ``follower``, if its id is one the wire allows."""
    return (follower, reply_prefix(follower)) if id_fits(follower) else None


def unpack_reply(data: bytes, expected: Expected | None = None) -> Reply | None:
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
        seq, rt, st = fields[1], fields[3], fields[5]
        if (_PICK_NOTHING(fields) != _NOTHING_CONSTANTS or seq > MAX_INT
                or rt - rt != 0.0 or st - st != 0.0):
            return None
        return Reply(follower, seq, rt, st, None)
    if rest < _FRAGMENT.size:
        return None
    fields = _FRAGMENT.unpack_from(data, at)
    (_, seq, _, rt, _, st, _, update_seq, _, generated_at, _, index, _, count, _, total, _,
     crc, _, length) = fields
    if (_PICK_FRAGMENT(fields) != _FRAGMENT_CONSTANTS or length != rest - _FRAGMENT.size
            or seq > MAX_INT or update_seq > MAX_INT or not index < count
            or not length <= total <= MAX_SIZE
            or rt - rt != 0.0 or st - st != 0.0 or generated_at - generated_at != 0.0):
        return None
    payload = data[at + _FRAGMENT.size:]
    return Reply(follower, seq, rt, st,
                 FragmentData(update_seq, generated_at, index, count, total, crc, payload))
