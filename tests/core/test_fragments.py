"""Splitting an update into fragments and reassembling it at the leader."""

from __future__ import annotations

import dataclasses

import pytest

from wiswarm_zenoh.core import Follower, FollowerConfig
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.fragments import OutgoingUpdate, Reassembler, checksum, verify_checksum
from wiswarm_zenoh.core.queues import Update
from wiswarm_zenoh.core.wire import FragmentData, Poll, decode_reply, encode_poll


def _outgoing(size: int, chunk: int, seq: int = 1) -> OutgoingUpdate:
    payload = bytes((i * 7 + seq) % 256 for i in range(size))
    return OutgoingUpdate(Update(seq=seq, generated_at=2.5, payload=payload), chunk=chunk)


def _all_fragments(out: OutgoingUpdate) -> list[FragmentData]:
    frags = []
    while not out.done:
        frag = out.fragment()
        frags.append(frag)
        out.acknowledge(frag.update_seq, frag.index)
    return frags


@pytest.mark.parametrize(("size", "chunk", "count"), [
    (0, 10, 1), (1, 10, 1), (10, 10, 1), (11, 10, 2), (25, 10, 3), (30, 10, 3),
])
def test_fragment_count_and_sizes(size: int, chunk: int, count: int) -> None:
    out = _outgoing(size, chunk)
    assert out.count == count
    frags = _all_fragments(out)
    assert [f.index for f in frags] == list(range(count))
    assert all(len(f.data) <= chunk for f in frags)
    assert all(len(f.data) == chunk for f in frags[:-1])
    assert b"".join(f.data for f in frags) == out.update.payload
    assert {(f.count, f.total_size, f.checksum) for f in frags} == {
        (count, size, checksum(out.update.payload))
    }


def test_fragment_size_leaves_room_for_the_header() -> None:
    follower = Follower("uav1", FollowerConfig(fragment_size=FRAGMENT_HEADER_BYTES + 44))
    follower.offer(bytes(1000), 0.0)
    reply = decode_reply(follower.on_poll(encode_poll(Poll(1, 0.0, None)), 0.0, 0.0))
    assert reply.fragment is not None
    assert len(reply.fragment.data) == 44
    assert reply.fragment.count == -(-1000 // 44)


def test_fragment_is_resent_until_acknowledged() -> None:
    out = _outgoing(25, 10)
    first = out.fragment()
    assert out.fragment() == first  # no ack: the same fragment again
    out.acknowledge(1, 1)  # ack of a fragment not sent yet: ignored
    out.acknowledge(2, 0)  # ack of another update: ignored
    assert out.fragment() == first
    out.acknowledge(1, 0)
    assert out.fragment().index == 1
    out.acknowledge(1, 0)  # duplicate of an old ack: ignored
    assert out.fragment().index == 1
    out.acknowledge(1, 1)
    out.acknowledge(1, 2)
    assert out.done


def test_reassembler_round_trip_ignores_duplicates_and_order() -> None:
    out = _outgoing(95, 10)
    frags = _all_fragments(out)
    r = Reassembler(max_fragments=100, max_update_bytes=1000)
    order = [*reversed(frags[1:]), frags[3], frags[5]]
    assert all(r.add(f) is None for f in order)
    assert r.add(frags[0]) == out.update.payload
    assert r.add(frags[0]) is None  # starts a fresh collection after completing


def test_reassembler_starts_over_on_a_fragment_of_another_update() -> None:
    old, new = _all_fragments(_outgoing(30, 10, seq=1)), _all_fragments(_outgoing(30, 10, seq=2))
    r = Reassembler(100, 1000)
    assert r.add(old[0]) is None and r.add(old[1]) is None
    assert r.add(new[0]) is None
    assert r.add(old[2]) is None  # the old update's parts were dropped
    r2 = Reassembler(100, 1000)
    for f in new[:2]:
        r2.add(f)
    assert r2.add(new[2]) == b"".join(f.data for f in new)


def test_a_damaged_fragment_fails_the_checksum_and_the_next_collection_starts_clean() -> None:
    frags = _all_fragments(_outgoing(30, 10))
    bad = dataclasses.replace(frags[1], data=b"X" * 10)
    r = Reassembler(100, 1000)
    r.add(frags[0])
    r.add(bad)
    whole = r.add(frags[2])
    assert whole is not None
    with pytest.raises(WireError, match="checksum"):
        verify_checksum(whole, frags[2])
    assert all(r.add(f) is None for f in frags[:2])
    whole = r.add(frags[2])
    assert whole == b"".join(f.data for f in frags)
    verify_checksum(whole, frags[2])


def test_reassembler_rejects_size_mismatches() -> None:
    r = Reassembler(100, 1000)
    too_long = FragmentData(1, 0.0, 0, 2, 5, 0, b"123456")
    with pytest.raises(WireError, match="more than"):
        r.add(too_long)
    short = FragmentData(1, 0.0, 0, 1, 5, checksum(b"1234"), b"1234")
    with pytest.raises(WireError, match="expected 5"):
        r.add(short)


@pytest.mark.parametrize(("count", "size", "field"), [(11, 10, "fragments"), (1, 1001, "bytes")])
def test_reassembler_limits(count: int, size: int, field: str) -> None:
    r = Reassembler(max_fragments=10, max_update_bytes=1000)
    with pytest.raises(WireError, match=field):
        r.add(FragmentData(1, 0.0, 0, count, size, 0, b""))


def test_reassembler_accepts_updates_at_the_limits() -> None:
    out = _outgoing(1000, 100)
    r = Reassembler(max_fragments=10, max_update_bytes=1000)
    results = [r.add(f) for f in _all_fragments(out)]
    assert results[-1] == out.update.payload
