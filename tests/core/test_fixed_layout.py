"""The fixed layout of polls and replies: it reads back what it wrote, it never accepts
bytes the strict general decoder refuses or reads differently, and anything else still
goes through the general decoder."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.core.build import pure_python_only
from wiswarm_zenoh.core import WireError, fixed_layout
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.core.fixed_layout import expect, reply_prefix, unpack_poll, unpack_reply
from wiswarm_zenoh.core.messages import MAX_ID_BYTES, MAX_INT, MAX_SIZE, UINT32
from wiswarm_zenoh.core.wire import (
    FragmentData,
    Poll,
    Reply,
    decode_poll,
    decode_poll_strict,
    decode_reply,
    decode_reply_strict,
    encode_poll,
    encode_reply,
)

EXAMPLES = settings(max_examples=300, derandomize=True, deadline=None)
UINT64 = 2**64 - 1
finite = st.floats(allow_nan=False, allow_infinity=False)
seqs = st.integers(0, MAX_INT)
ids = st.text(st.characters(codec="utf-8"), min_size=1, max_size=MAX_ID_BYTES // 4)
polls = st.builds(Poll, seqs, finite, st.none() | st.tuples(seqs, st.integers(0, UINT32)),
                  st.sampled_from(["next", "fresh"]), seqs)


@st.composite
def fragments(draw: st.DrawFn) -> FragmentData:
    count = draw(st.integers(1, UINT32))
    data = draw(st.binary(max_size=64))
    return FragmentData(draw(seqs), draw(finite), draw(st.integers(0, count - 1)), count,
                        draw(st.integers(len(data), MAX_SIZE)), draw(st.integers(0, UINT32)),
                        data)


replies = st.builds(Reply, ids, seqs, finite, finite, st.none() | fragments())
mutations = (st.integers(0, 10**6), st.integers(0, 2), st.integers(0, 255))

Decoder = Callable[[bytes], Any]


def _same_verdict(fast: Decoder, strict: Decoder, data: bytes, *, exact_layout: bool) -> None:
    """``fast`` accepts only what ``strict`` accepts, and reads the same; on bytes in the
    exact layout it also accepts everything ``strict`` accepts."""
    got = fast(data)
    try:
        expected = strict(data)
    except WireError:
        assert got is None
        return
    if got is not None or exact_layout:
        assert got == expected


def _mutated(data: bytes, where: int, how: int, value: int) -> bytes:
    where %= len(data) + 1
    if how == 0:  # change one byte
        where %= len(data)
        return data[:where] + bytes([value]) + data[where + 1:]
    if how == 1:  # cut short
        return data[:where]
    return data[:where] + bytes([value]) + data[where:]  # one byte too many


# Each message with its strategy, encoder, fast reader and strict reader.
Codec = tuple[st.SearchStrategy[Any], Callable[[Any], bytes], Decoder, Decoder]
CODECS: dict[str, Codec] = {
    "poll": (polls, encode_poll, unpack_poll, decode_poll_strict),
    "reply": (replies, encode_reply, unpack_reply, decode_reply_strict),
}


@pytest.mark.parametrize("kind", CODECS)
@EXAMPLES
@given(data=st.data())
def test_valid_messages_read_back_the_same_either_way(kind: str, data: st.DataObject) -> None:
    messages, encode, fast, strict = CODECS[kind]
    _same_verdict(fast, strict, encode(data.draw(messages)), exact_layout=True)


@pytest.mark.parametrize("kind", CODECS)
@EXAMPLES
@given(data=st.data(), where=mutations[0], how=mutations[1], value=mutations[2])
def test_damaged_messages_are_never_read_otherwise_than_by_the_strict_decoder(
        kind: str, data: st.DataObject, where: int, how: int, value: int) -> None:
    messages, encode, fast, strict = CODECS[kind]
    damaged = _mutated(encode(data.draw(messages)), where, how, value)
    _same_verdict(fast, strict, damaged, exact_layout=False)


@pytest.mark.parametrize("poll", [Poll(0, 0.0, None), Poll(MAX_INT, -1.5, (MAX_INT, UINT32),
                                                          "fresh", MAX_INT)])
def test_the_fast_path_reads_what_the_leader_sends(poll: Poll) -> None:
    assert unpack_poll(encode_poll(poll)) == poll


def test_the_shortest_msgpack_encoding_goes_through_the_general_decoder() -> None:
    """A follower written in another language packs the same maps its own way."""
    poll = {"v": 2, "t": "poll", "seq": 5, "lt": 2.5, "e": 9, "ack": [3, 0], "want": "next"}
    reply = {"v": 2, "t": "reply", "from": "uav1", "poll": 5, "rt": 1.0, "st": 1.5,
             "frag": {"u": 3, "g": 0.5, "i": 0, "n": 1, "size": 3, "crc": 7, "data": b"abc"}}
    poll_bytes = msgpack.packb(poll, use_bin_type=True)
    reply_bytes = msgpack.packb(reply, use_bin_type=True)
    assert unpack_poll(poll_bytes) is None
    assert unpack_reply(reply_bytes) is None
    assert decode_poll(poll_bytes) == Poll(5, 2.5, (3, 0), "next", 9)
    assert decode_reply(reply_bytes) == Reply(
        "uav1", 5, 1.0, 1.5, FragmentData(3, 0.5, 0, 1, 3, 7, b"abc"))


FRAG = FragmentData(3, 0.5, 1, 2, 100, 7, b"abc")
# (A value its wire type holds but the protocol forbids: see test_message_rules.py.)


def test_a_reply_whose_data_length_disagrees_is_left_to_the_strict_decoder() -> None:
    data = encode_reply(Reply("uav1", 1, 0.0, 0.0, FRAG))
    for damaged in (data[:-1], data + b"x"):
        assert unpack_reply(damaged) is None
        with pytest.raises(WireError):
            decode_reply(damaged)


@pytest.mark.parametrize("length", [0, MAX_ID_BYTES + 1])
def test_a_sender_id_of_a_forbidden_length_is_left_to_the_strict_decoder(length: int) -> None:
    data = encode_reply(Reply("x" * length, 1, 0.0, 0.0, None))
    assert unpack_reply(data) is None
    with pytest.raises(WireError):
        decode_reply(data)


def test_the_reply_header_fits_the_room_left_for_it_in_a_fragment() -> None:
    frag = FragmentData(MAX_INT, 1.0, UINT32 - 1, UINT32, 2**40, UINT32, b"")
    longest = "\u00e9" * (MAX_ID_BYTES // 2)  # two UTF-8 bytes each
    assert len(encode_reply(Reply(longest, MAX_INT, 1.0, 1.0, frag))) <= FRAGMENT_HEADER_BYTES


@EXAMPLES
@given(replies, st.booleans(), ids)
def test_expecting_a_sender_changes_nothing_but_the_work(reply: Reply, from_polled: bool,
                                                         other: str) -> None:
    """Told whom it polled, the reader skips parsing that id; a reply from anyone else
    is still read in full (and then its sender is the one it claims)."""
    data = encode_reply(reply)
    polled = reply.follower if from_polled else other
    assert unpack_reply(data, polled) == unpack_reply(data) == reply


@pure_python_only
def test_the_polled_followers_id_is_not_parsed(monkeypatch: pytest.MonkeyPatch) -> None:
    reply = Reply("uav1", 1, 0.0, 0.0, FRAG)
    data = encode_reply(reply)
    monkeypatch.setattr(fixed_layout, "_sender", lambda data: None)  # parse nothing
    assert unpack_reply(data) is None
    assert unpack_reply(data, "uav2") is None
    assert unpack_reply(data, "uav1") == reply


def test_no_shortcut_is_expected_of_an_id_the_wire_refuses() -> None:
    assert expect("x" * (MAX_ID_BYTES + 1)) is None
    assert expect("") is None
    assert expect("uav1") == ("uav1", reply_prefix("uav1"))


@pure_python_only
def test_what_to_expect_is_kept_for_a_swarm_and_no_more(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fixed_layout, "_expected", {})
    monkeypatch.setattr(fixed_layout, "_EXPECTED_KEPT", 3)
    first = expect("uav1")
    assert expect("uav1") is first
    for n in range(10):
        expect(f"extra{n}")
    assert len(fixed_layout._expected) == 3
    late = expect("uav9")
    assert late == ("uav9", reply_prefix("uav9")) and expect("uav9") is not late
    assert unpack_reply(encode_reply(Reply("uav9", 1, 0.0, 0.0, None)), "uav9") is not None
