"""Wire messages (DESIGN.md section 4): msgpack maps with a format version ``v``.

Decoders check every type, size and range and raise nothing but ``WireError``: the bytes
come from the network and may be anything.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NoReturn

import msgpack
from zlib_ng import zlib_ng

from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.fixed_layout import (
    Expected,
    pack_poll,
    pack_reply,
    reply_prefix,
    unpack_poll,
    unpack_reply,
)
from wiswarm_zenoh.core.messages import (
    MAX_CONTROL_ENTRIES,
    MAX_ID_BYTES,
    MAX_INT,
    MAX_SIZE,
    MAX_WAYPOINTS,
    UINT32,
    VERSION,
    Control,
    FragmentData,
    Poll,
    Reply,
    Want,
    Waypoint,
    id_fits,
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


def _pack(obj: dict[str, Any]) -> bytes:
    packed: bytes = msgpack.packb(obj, use_bin_type=True)
    return packed


def _unpack(data: bytes, kind: str) -> dict[str, Any]:
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


# Decoders run on every poll and reply: they test the common case inline (``x - x`` is
# 0.0 for a finite float only) and call these helpers, which say what is wrong, when it
# fails. A short id (at most 32 characters) fits MAX_ID_BYTES in any encoding.
SHORT_ID = MAX_ID_BYTES // 4


def _int(obj: Mapping[str, Any], key: str, lo: int = 0, hi: int = MAX_INT) -> int:
    value = obj.get(key)
    if type(value) is not int or not lo <= value <= hi:
        raise WireError(f"field {key!r} must be an integer in [{lo}, {hi}], got {value!r}")
    return value


def _float(obj: Mapping[str, Any], key: str) -> float:
    value = obj.get(key)
    if not (isinstance(value, float | int) and not isinstance(value, bool)):
        raise WireError(f"field {key!r} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise WireError(f"field {key!r} must be finite, got {value!r}")
    return float(value)


def _ident(value: object, what: str) -> str:
    if not (isinstance(value, str) and id_fits(value)):
        raise WireError(f"{what} must be a non-empty string of at most {MAX_ID_BYTES} bytes")
    return value


def encode_poll(poll: Poll) -> bytes:
    return pack_poll(poll)


def decode_poll(data: bytes) -> Poll:
    """A poll in the fixed layout the leader sends, or else in any valid encoding."""
    poll = unpack_poll(data) if type(data) is bytes else None
    return _decode_poll_any(data) if poll is None else poll


def _decode_poll_any(data: bytes) -> Poll:
    obj = _unpack(data, "poll")
    seq, lt = obj.get("seq"), obj.get("lt")
    if type(seq) is not int or not 0 <= seq <= MAX_INT:
        seq = _int(obj, "seq")
    if type(lt) is not float or lt - lt != 0.0:
        lt = _float(obj, "lt")
    ack_raw = obj.get("ack")
    ack: tuple[int, int] | None = None
    if ack_raw is not None:
        if not isinstance(ack_raw, list) or len(ack_raw) != 2:
            raise WireError("field 'ack' must be null or [update_seq, index]")
        acked, index = ack_raw
        if type(acked) is not int or type(index) is not int or not (
            0 <= acked <= MAX_INT and 0 <= index <= UINT32
        ):
            raise WireError(f"field 'ack' must be [update_seq, index] in range, got {ack_raw!r}")
        ack = (acked, index)
    want = obj.get("want")
    if want not in ("next", "fresh"):
        raise WireError(f"field 'want' must be 'next' or 'fresh', got {want!r}")
    return Poll(seq, lt, ack, want, _int(obj, "e"))


def encode_reply(reply: Reply) -> bytes:
    return pack_reply(reply_prefix(reply.follower), reply.poll_seq, reply.received_at,
                      reply.sent_at, reply.fragment)


def _decode_fragment(body: object) -> FragmentData:
    if not isinstance(body, dict):
        raise WireError("field 'frag' must be null or a map")
    data = body.get("data")
    if not isinstance(data, bytes):
        raise WireError("fragment 'data' must be bytes")
    seq, at, index, count = body.get("u"), body.get("g"), body.get("i"), body.get("n")
    total, crc = body.get("size"), body.get("crc")
    if not (type(seq) is int and type(index) is int and type(count) is int
            and type(total) is int and type(crc) is int and 0 <= seq <= MAX_INT
            and 0 <= index < count <= UINT32 and len(data) <= total <= MAX_SIZE
            and 0 <= crc <= UINT32):
        _fragment_error(body, data)
    if type(at) is not float or at - at != 0.0:
        at = _float(body, "g")
    return FragmentData(seq, at, index, count, total, crc, data)


def _fragment_error(body: dict[str, Any], data: bytes) -> NoReturn:
    """Raise the WireError that says which fragment field is wrong."""
    count = _int(body, "n", lo=1, hi=UINT32)
    _int(body, "i", hi=count - 1)
    total = _int(body, "size", hi=MAX_SIZE)
    if len(data) > total:
        raise WireError(f"fragment of {len(data)} bytes exceeds the update's size {total}")
    _int(body, "u")
    _int(body, "crc", hi=UINT32)
    raise WireError("malformed fragment")  # unreachable: one of the checks above failed


def decode_reply(data: bytes, expected: Expected | None = None) -> Reply:
    """A reply in the fixed layout followers send, or else in any valid encoding
    (``expected``: see ``fixed_layout.expect``)."""
    reply = unpack_reply(data, expected) if type(data) is bytes else None
    return _decode_reply_any(data) if reply is None else reply


def _decode_reply_any(data: bytes) -> Reply:
    obj = _unpack(data, "reply")
    sender, seq, rt, st = obj.get("from"), obj.get("poll"), obj.get("rt"), obj.get("st")
    if type(sender) is not str or not 0 < len(sender) <= SHORT_ID:
        sender = _ident(sender, "field 'from'")
    if type(seq) is not int or not 0 <= seq <= MAX_INT:
        seq = _int(obj, "poll")
    if type(rt) is not float or rt - rt != 0.0:
        rt = _float(obj, "rt")
    if type(st) is not float or st - st != 0.0:
        st = _float(obj, "st")
    body = obj.get("frag")
    return Reply(sender, seq, rt, st, None if body is None else _decode_fragment(body))


def validate_waypoints(waypoints: Sequence[Sequence[float]]) -> list[Waypoint]:
    """Check a caller's waypoints: a list of at most MAX_WAYPOINTS finite (t, x, y, z)."""
    if len(waypoints) > MAX_WAYPOINTS:
        raise ValueError(f"at most {MAX_WAYPOINTS} waypoints, got {len(waypoints)}")
    checked: list[Waypoint] = []
    for wp in waypoints:
        if len(wp) != 4 or not all(math.isfinite(float(c)) for c in wp):
            raise ValueError(f"a waypoint must be 4 finite numbers (t, x, y, z), got {wp!r}")
        checked.append((float(wp[0]), float(wp[1]), float(wp[2]), float(wp[3])))
    return checked


def pack_entries(entries: Mapping[str, Sequence[Waypoint]]) -> bytes:
    """The msgpack of a control message's entries, to cache while they do not change."""
    return _pack({k: [list(w) for w in v] for k, v in entries.items()})


_CONTROL_HEAD = b"\x86" + b"".join(msgpack.packb(x) for x in ("v", VERSION, "t", "control"))
_SEQ, _LT, _EPOCH, _ENTRIES = (msgpack.packb(k) for k in ("seq", "lt", "e", "entries"))


def encode_control_packed(seq: int, leader_time: float, packed_entries: bytes,
                          epoch: int) -> bytes:
    """A control message around already packed entries: the leader sends one per poll,
    and re-encoding every follower's waypoints each time would cost O(N) per poll."""
    return b"".join(
        (_CONTROL_HEAD, _SEQ, msgpack.packb(seq), _LT, msgpack.packb(float(leader_time)),
         _EPOCH, msgpack.packb(epoch), _ENTRIES, packed_entries)
    )


def encode_control(control: Control) -> bytes:
    return encode_control_packed(control.seq, control.leader_time,
                                 pack_entries(control.entries), control.epoch)


def _decode_waypoints(raw: object) -> list[Waypoint]:
    if not isinstance(raw, list) or len(raw) > MAX_WAYPOINTS:
        raise WireError(f"control entry must be a list of at most {MAX_WAYPOINTS} waypoints")
    for wp in raw:
        if not isinstance(wp, list) or any(type(c) not in (int, float) for c in wp):
            raise WireError(f"a waypoint must be a list of numbers, got {wp!r}")
    try:
        return validate_waypoints(raw)
    except (ValueError, TypeError) as exc:
        raise WireError(f"bad waypoint: {exc}") from None


def decode_control(data: bytes) -> Control:
    obj = _unpack(data, "control")
    entries_raw = obj.get("entries")
    if not isinstance(entries_raw, dict) or len(entries_raw) > MAX_CONTROL_ENTRIES:
        raise WireError("field 'entries' must be a map of follower id to waypoints")
    entries = {
        _ident(k, "control entry key"): _decode_waypoints(v) for k, v in entries_raw.items()
    }
    return Control(seq=_int(obj, "seq"), leader_time=_float(obj, "lt"), entries=entries,
                   epoch=_int(obj, "e"))
