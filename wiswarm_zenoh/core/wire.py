"""Wire messages (DESIGN.md section 4): msgpack maps with a format version ``v``.

Decoders check every type, size and range and raise nothing but ``WireError``: the bytes
come from the network and may be anything. Polls and replies are read in the fixed layout
(``fixed_layout``) when they are in it, else by the strict decoders here, which check each
field's type; both then apply the message's one checker of the protocol's rules
(``messages``), so a value one refuses the other refuses too, for the same reason.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeGuard, cast

import msgpack
from zlib_ng import zlib_ng

from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.fixed_layout import (
    pack_poll,
    pack_reply,
    reply_prefix,
    unpack_poll,
    unpack_reply,
)
from wiswarm_zenoh.core.messages import (
    ID_RULE,
    MAX_ID_BYTES,
    MAX_WAYPOINTS,
    UINT32,
    UINT64,
    VERSION,
    WANTS,
    Control,
    FragmentData,
    Poll,
    Reply,
    Want,
    Waypoint,
    control_fault,
    id_fits,
    poll_fault,
    reply_fault,
    waypoints_fault,
)

__all__ = [
    "MAX_ID_BYTES", "MAX_WAYPOINTS", "UINT32", "Control", "FragmentData", "Poll", "Reply",
    "Want", "Waypoint", "checksum", "decode_control", "decode_poll", "decode_reply",
    "encode_control", "encode_control_packed", "encode_poll", "encode_reply", "id_fits",
    "pack_entries", "pack_reply", "reply_prefix", "validate_waypoints",
]

# The checksum a fragment carries: CRC-32 of the whole update (unsigned), the same
# numbers as ``zlib.crc32``. zlib-ng computes it with carry-less multiply instructions,
# about 12x faster than the stdlib's zlib (1 us for a 50 kB frame instead of 12): each
# update is checked once at each end of its poll.
checksum: Callable[[bytes], int] = zlib_ng.crc32

_pack: Callable[[object], bytes] = msgpack.packb  # bytes as bin, str as str (msgpack >= 1)
encode_poll = pack_poll  # the leader's polls are all in the fixed layout


def _unpack(data: object, kind: str) -> dict[str, Any]:
    if type(data) is not bytes:
        if not isinstance(data, bytes | bytearray | memoryview):
            raise WireError(f"{kind}: expected bytes, got {type(data).__name__}")
        data = bytes(data)
    try:
        obj = msgpack.unpackb(data, raw=False, strict_map_key=True, use_list=True)
    except Exception as exc:  # msgpack raises many types on garbage
        raise WireError(f"{kind}: not msgpack ({type(exc).__name__})") from None
    if not isinstance(obj, dict):
        raise WireError(f"{kind}: expected a map, got {type(obj).__name__}")
    if type(obj.get("v")) is not int or obj["v"] != VERSION:
        raise WireError(f"{kind}: unsupported version {obj.get('v')!r}")
    if obj.get("t") != kind:
        raise WireError(f"expected a {kind} message, got {obj.get('t')!r}")
    return obj


# Readers of a field's wire type (what is asked beyond it is the message's checker's).
# msgpack's true and false are not integers here, and an integer is also a number.

def _is_uint(value: object, hi: int) -> TypeGuard[int]:
    return type(value) is int and 0 <= value <= hi


def _uint(obj: Mapping[str, Any], key: str, hi: int = UINT64, within: str = "") -> int:
    value = obj.get(key)
    if not _is_uint(value, hi):
        raise WireError(f"field '{within}{key}' must be an integer in [0, {hi}], got {value!r}")
    return value


def _float(obj: Mapping[str, Any], key: str, within: str = "") -> float:
    value = obj.get(key)
    if type(value) is float:
        return value
    if type(value) is int:
        return float(value)
    raise WireError(f"field '{within}{key}' must be a number, got {value!r}")


def _check(fault: str | None) -> None:
    """Raise what a message's checker found wrong, if anything."""
    if fault is not None:
        raise WireError(fault)


def decode_poll(data: object) -> Poll:
    """A poll in the fixed layout the leader sends, or else in any valid encoding.
    Decoders take any object (bytes-like is decoded; anything else is a ``WireError``):
    the check is theirs, so that the compiled core refuses alike."""
    poll = unpack_poll(data) if type(data) is bytes else None
    return decode_poll_strict(data) if poll is None else poll


def decode_poll_strict(data: object) -> Poll:
    obj = _unpack(data, "poll")
    ack_raw = obj.get("ack")
    ack: tuple[int, int] | None = None
    if ack_raw is not None:
        if not (isinstance(ack_raw, list) and len(ack_raw) == 2
                and _is_uint(ack_raw[0], UINT64) and _is_uint(ack_raw[1], UINT32)):
            raise WireError("field 'ack' must be null or [update_seq, index] in [0, "
                            f"{UINT64}] x [0, {UINT32}], got {ack_raw!r}")
        ack = (ack_raw[0], ack_raw[1])
    want = obj.get("want")
    if want not in WANTS:  # a type (Literal): the fixed layout has a shape for each
        raise WireError(f"field 'want' must be one of {WANTS}, got {want!r}")
    poll = Poll(_uint(obj, "seq"), _float(obj, "lt"), ack, cast(Want, want), _uint(obj, "e"))
    _check(poll_fault(poll))
    return poll


def encode_reply(reply: Reply) -> bytes:
    return pack_reply(reply_prefix(reply.follower), reply.poll_seq, reply.received_at,
                      reply.sent_at, reply.fragment)


def decode_reply(data: object, follower: str | None = None) -> Reply:
    """A reply in the fixed layout followers send, or else in any valid encoding.
    ``follower``, whom the reply answers, spares parsing that id (see ``unpack_reply``)."""
    reply = unpack_reply(data, follower) if type(data) is bytes else None
    return decode_reply_strict(data) if reply is None else reply


def _decode_fragment(body: object) -> FragmentData:
    if not isinstance(body, dict):
        raise WireError("field 'frag' must be null or a map")
    data = body.get("data")
    if not isinstance(data, bytes):
        raise WireError(f"field 'frag.data' must be bytes, got {type(data).__name__}")
    at = "frag."
    return FragmentData(_uint(body, "u", within=at), _float(body, "g", at),
                        _uint(body, "i", UINT32, at), _uint(body, "n", UINT32, at),
                        _uint(body, "size", within=at), _uint(body, "crc", UINT32, at), data)


def decode_reply_strict(data: object) -> Reply:
    obj = _unpack(data, "reply")
    sender = obj.get("from")
    if not id_fits(sender):
        raise WireError(f"field 'from' must be {ID_RULE}, got {sender!r}")
    body = obj.get("frag")
    reply = Reply(sender, _uint(obj, "poll"), _float(obj, "rt"), _float(obj, "st"),
                  None if body is None else _decode_fragment(body))
    _check(reply_fault(reply))
    return reply


def validate_waypoints(waypoints: Sequence[Sequence[float]]) -> list[Waypoint]:
    """A caller's waypoints as floats, if they fit (``messages.waypoints_fault``)."""
    fault = waypoints_fault(waypoints)
    if fault is not None:
        raise ValueError(fault)
    return _floats(waypoints)


def _floats(waypoints: Sequence[Sequence[float]]) -> list[Waypoint]:
    """Checked waypoints as tuples of floats (the wire may carry integers)."""
    return [(float(t), float(x), float(y), float(z)) for t, x, y, z in waypoints]


def pack_entries(entries: Mapping[str, Sequence[Waypoint]]) -> bytes:
    """The msgpack of a control message's entries, to cache while they do not change."""
    return _pack({k: [list(w) for w in v] for k, v in entries.items()})


_CONTROL_HEAD = b"\x86" + b"".join(_pack(x) for x in ("v", VERSION, "t", "control"))
_SEQ, _LT, _EPOCH, _ENTRIES = (_pack(k) for k in ("seq", "lt", "e", "entries"))


def encode_control_packed(seq: int, leader_time: float, packed_entries: bytes,
                          epoch: int) -> bytes:
    """A control message around already packed entries: the leader sends one per poll,
    and re-encoding every follower's waypoints each time would cost O(N) per poll."""
    return b"".join(
        (_CONTROL_HEAD, _SEQ, _pack(seq), _LT, _pack(float(leader_time)), _EPOCH,
         _pack(epoch), _ENTRIES, packed_entries)
    )


def encode_control(control: Control) -> bytes:
    """A control message as the leader puts it on ``wiswarm/<swarm>/control``."""
    return encode_control_packed(control.seq, control.leader_time,
                                 pack_entries(control.entries), control.epoch)


def _number_lists(raw: object) -> bool:
    """Whether ``raw`` is a list of lists of numbers (an entry's waypoints, unchecked)."""
    return isinstance(raw, list) and all(
        isinstance(wp, list) and all(type(c) is float or type(c) is int for c in wp)
        for wp in raw)


def decode_control(data: object) -> Control:
    obj = _unpack(data, "control")
    entries = obj.get("entries")
    if not (isinstance(entries, dict) and all(_number_lists(v) for v in entries.values())):
        raise WireError("field 'entries' must be a map of follower id to lists of numbers")
    seq, leader_time, epoch = _uint(obj, "seq"), _float(obj, "lt"), _uint(obj, "e")
    _check(control_fault(Control(seq, leader_time, entries, epoch)))
    return Control(seq, leader_time, {k: _floats(v) for k, v in entries.items()}, epoch)
