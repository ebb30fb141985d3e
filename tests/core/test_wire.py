"""Wire messages: round trips, and strict rejection of anything else as WireError."""

from __future__ import annotations

import math
import random
import zlib
from collections.abc import Callable
from typing import Any

import msgpack
import pytest

from wiswarm_zenoh.core import WireError
from wiswarm_zenoh.core.messages import VERSION
from wiswarm_zenoh.core.wire import (
    MAX_ID_BYTES,
    MAX_WAYPOINTS,
    UINT32,
    Control,
    FragmentData,
    Poll,
    Reply,
    checksum,
    decode_control,
    decode_poll,
    decode_reply,
    encode_control,
    encode_poll,
    encode_reply,
    validate_waypoints,
)

FRAG = FragmentData(update_seq=3, generated_at=12.25, index=1, count=4, total_size=40,
                    checksum=UINT32, data=b"0123456789")
REPLY = Reply(follower="uav1", poll_seq=9, received_at=1.5, sent_at=1.75, fragment=FRAG)
POLL = Poll(seq=2**40, leader_time=-3.5, ack=(7, UINT32), want="fresh")
CONTROL = Control(seq=4, leader_time=100.0, entries={
    "uav1": [(1.0, 2.0, 3.0, 4.0), (5.0, 6.0, 7.0, -8.0)], "uav2": [],
})


def _map(data: bytes) -> dict[str, Any]:
    obj: dict[str, Any] = msgpack.unpackb(data)
    return obj


def _pack(obj: object) -> bytes:
    packed: bytes = msgpack.packb(obj, use_bin_type=True)
    return packed


@pytest.mark.parametrize("poll", [POLL, Poll(0, 0.0, None), Poll(1, 1e9, (0, 0), "next")])
def test_poll_round_trip(poll: Poll) -> None:
    assert decode_poll(encode_poll(poll)) == poll


@pytest.mark.parametrize("reply", [REPLY, Reply("x" * MAX_ID_BYTES, 0, 0.0, 0.0, None)])
def test_reply_round_trip(reply: Reply) -> None:
    assert decode_reply(encode_reply(reply)) == reply


def test_control_round_trip() -> None:
    decoded = decode_control(encode_control(CONTROL))
    assert (decoded.seq, decoded.leader_time) == (CONTROL.seq, CONTROL.leader_time)
    assert decoded.entries == {k: list(v) for k, v in CONTROL.entries.items()}


def test_integer_coordinates_are_accepted_as_floats() -> None:
    raw = _map(encode_control(CONTROL))
    raw["entries"] = {"uav1": [[1, 2, 3, 4]]}
    assert decode_control(_pack(raw)).entries == {"uav1": [(1.0, 2.0, 3.0, 4.0)]}


def test_messages_are_versioned_and_typed() -> None:
    for raw in (encode_poll(POLL), encode_reply(REPLY), encode_control(CONTROL)):
        assert _map(raw)["v"] == VERSION
    with pytest.raises(WireError, match="poll"):
        decode_poll(encode_reply(REPLY))
    with pytest.raises(WireError):
        decode_reply(encode_poll(POLL))
    with pytest.raises(WireError):
        decode_control(encode_poll(POLL))


Decoder = Callable[[bytes], object]
BASES: list[tuple[Decoder, bytes]] = [
    (decode_poll, encode_poll(POLL)),
    (decode_reply, encode_reply(REPLY)),
    (decode_control, encode_control(CONTROL)),
]


def _with_version(base: bytes, version: object) -> bytes:
    raw = _map(base)
    if version is None:
        del raw["v"]
    else:
        raw["v"] = version
    return _pack(raw)


@pytest.mark.parametrize(("decode", "base"), BASES, ids=["poll", "reply", "control"])
@pytest.mark.parametrize("version", [None, 0, 1, VERSION + 1, str(VERSION), [VERSION]])
def test_wrong_version_is_rejected(decode: Decoder, base: bytes, version: object) -> None:
    with pytest.raises(WireError):
        decode(_with_version(base, version))


def test_version_must_be_the_integer_one_not_true_or_a_float() -> None:
    """msgpack's true and 1.0 compare equal to 1 in Python; the wire says integer 1."""
    accepted = []
    for decode, base in BASES:
        for version in (True, 1.0):
            try:
                decode(_with_version(base, version))
                accepted.append((decode.__name__, version))
            except WireError:
                pass
    assert accepted == []


def _mutated(base: bytes, path: tuple[str | int, ...], value: object) -> bytes:
    obj = _map(base)
    target: Any = obj
    for key in path[:-1]:
        target = target[key]
    if value is KeyError:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return _pack(obj)


POLL_BAD: list[tuple[tuple[str | int, ...], object]] = [
    (("seq",), -1), (("seq",), 1.0), (("seq",), True), (("seq",), "1"), (("seq",), KeyError),
    (("seq",), 2**63), (("lt",), math.nan), (("lt",), math.inf), (("lt",), False),
    (("lt",), "0"), (("lt",), None), (("ack",), [1]), (("ack",), [1, 2, 3]),
    (("ack",), {"u": 1, "i": 2}), (("ack",), [1, True]), (("ack",), [-1, 0]),
    (("ack",), [1, UINT32 + 1]), (("ack",), [1, 0.5]), (("want",), "all"),
    (("want",), KeyError), (("want",), True), (("t",), "reply"),
]


@pytest.mark.parametrize(("path", "value"), POLL_BAD)
def test_bad_poll_fields(path: tuple[str | int, ...], value: object) -> None:
    with pytest.raises(WireError):
        decode_poll(_mutated(encode_poll(POLL), path, value))


REPLY_BAD: list[tuple[tuple[str | int, ...], object]] = [
    (("from",), ""), (("from",), "x" * (MAX_ID_BYTES + 1)), (("from",), 7),
    (("from",), b"uav1"), (("poll",), -2), (("poll",), True), (("rt",), math.nan),
    (("st",), -math.inf), (("st",), True), (("frag",), []), (("frag",), "x"),
    (("frag", "data"), "text"), (("frag", "data"), None), (("frag", "data"), b"x" * 41),
    (("frag", "n"), 0), (("frag", "n"), UINT32 + 1), (("frag", "i"), 4), (("frag", "i"), -1),
    (("frag", "i"), True), (("frag", "size"), 2**40 + 1), (("frag", "size"), 5),
    (("frag", "crc"), UINT32 + 1), (("frag", "crc"), 1.5), (("frag", "g"), math.nan),
    (("frag", "g"), True), (("frag", "u"), KeyError), (("frag", "u"), -1),
]


@pytest.mark.parametrize(("path", "value"), REPLY_BAD)
def test_bad_reply_fields(path: tuple[str | int, ...], value: object) -> None:
    with pytest.raises(WireError):
        decode_reply(_mutated(encode_reply(REPLY), path, value))


# A wrong type (or shape) is reported by the field's wire key.
NAMED: list[tuple[Decoder, bytes, tuple[str | int, ...], object, str]] = [
    (decode_poll, encode_poll(POLL), ("seq",), True, "'seq'"),
    (decode_poll, encode_poll(POLL), ("seq",), -1, "'seq'"),
    (decode_poll, encode_poll(POLL), ("lt",), "0", "'lt'"),
    (decode_poll, encode_poll(POLL), ("e",), KeyError, "'e'"),
    (decode_poll, encode_poll(POLL), ("want",), "all", "'want'"),
    (decode_poll, encode_poll(POLL), ("ack",), [1, UINT32 + 1], "'ack'"),
    (decode_reply, encode_reply(REPLY), ("from",), "", "'from'"),
    (decode_reply, encode_reply(REPLY), ("poll",), 1.0, "'poll'"),
    (decode_reply, encode_reply(REPLY), ("st",), None, "'st'"),
    (decode_reply, encode_reply(REPLY), ("frag",), [], "'frag'"),
    (decode_reply, encode_reply(REPLY), ("frag", "data"), "text", "'frag.data'"),
    (decode_reply, encode_reply(REPLY), ("frag", "i"), True, "'frag.i'"),
    (decode_reply, encode_reply(REPLY), ("frag", "n"), UINT32 + 1, "'frag.n'"),
    (decode_reply, encode_reply(REPLY), ("frag", "crc"), -1, "'frag.crc'"),
    (decode_reply, encode_reply(REPLY), ("frag", "g"), "now", "'frag.g'"),
    (decode_control, encode_control(CONTROL), ("seq",), 1.5, "'seq'"),
    (decode_control, encode_control(CONTROL), ("entries",), {"a": [[0, "0", 0, 0]]},
     "'entries'"),
]


@pytest.mark.parametrize(("decode", "base", "path", "value", "named"), NAMED)
def test_a_bad_field_is_named(decode: Decoder, base: bytes, path: tuple[str | int, ...],
                              value: object, named: str) -> None:
    with pytest.raises(WireError, match=named):
        decode(_mutated(base, path, value))


CONTROL_BAD: list[tuple[tuple[str | int, ...], object]] = [
    (("seq",), -1), (("seq",), True), (("lt",), math.inf), (("entries",), []),
    (("entries",), {"": []}), (("entries",), {"x" * (MAX_ID_BYTES + 1): []}),
    (("entries",), {"a": [[0, 0, 0]]}), (("entries",), {"a": [[0, 0, 0, 0, 0]]}),
    (("entries",), {"a": [[0, 0, 0, math.nan]]}), (("entries",), {"a": [[0, 0, True, 0]]}),
    (("entries",), {"a": [[0, 0, "0", 0]]}), (("entries",), {"a": [(0, 0, 0, 0)] * 257}),
    (("entries",), {"a": "wp"}), (("entries",), {"a": [None]}), (("entries",), {"a": [[]]}),
]


@pytest.mark.parametrize(("path", "value"), CONTROL_BAD)
def test_bad_control_fields(path: tuple[str | int, ...], value: object) -> None:
    with pytest.raises(WireError):
        decode_control(_mutated(encode_control(CONTROL), path, value))


@pytest.mark.parametrize("decode", [decode_poll, decode_reply, decode_control])
@pytest.mark.parametrize("data", [
    b"", b"\xc1", b"\x92\x01\x02", _pack("poll"), _pack(None), _pack({1: 2}),
    encode_poll(POLL)[:-1], encode_poll(POLL) + b"\x00", "text", None, 42,
])
def test_not_a_message(decode: Decoder, data: Any) -> None:
    with pytest.raises(WireError):
        decode(data)


def test_memoryview_and_bytearray_are_accepted() -> None:
    raw = encode_poll(POLL)
    assert decode_poll(bytearray(raw)) == POLL  # type: ignore[arg-type]
    assert decode_poll(memoryview(raw)) == POLL  # type: ignore[arg-type]


def test_waypoint_validation_for_the_caller() -> None:
    assert validate_waypoints([[1, 2, 3, 4]]) == [(1.0, 2.0, 3.0, 4.0)]
    with pytest.raises(ValueError, match="at most"):
        validate_waypoints([(0.0, 0.0, 0.0, 0.0)] * (MAX_WAYPOINTS + 1))
    for bad in ([(0.0, 0.0, 0.0)], [(0.0, 0.0, 0.0, math.inf)]):
        with pytest.raises(ValueError, match="4 finite"):
            validate_waypoints(bad)


@pytest.mark.parametrize("size", [0, 1, 63, 64, 4095, 50176, 200_003])
def test_the_checksum_is_the_standard_crc32(size: int) -> None:
    """Any other implementation (a follower in C, a capture in Wireshark) must agree."""
    data = random.Random(size).randbytes(size)
    assert checksum(data) == zlib.crc32(data)
