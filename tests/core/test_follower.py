"""The follower state machine, driven with hand-made polls and control messages."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.core import Follower, FollowerConfig, WireError
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.core.wire import (
    Control,
    FragmentData,
    Poll,
    Reply,
    Want,
    decode_reply,
    encode_control,
    encode_poll,
    encode_reply,
)

SMALL = FRAGMENT_HEADER_BYTES + 10  # fragments of 10 payload bytes


class Driver:
    """Sends numbered polls to one follower and decodes its fragments."""

    def __init__(self, follower: Follower) -> None:
        self.follower = follower
        self.seq = 0

    def poll(self, now: float, ack: tuple[int, int] | None = None,
             want: Want = "next") -> FragmentData | None:
        self.seq += 1
        raw = self.follower.on_poll(encode_poll(Poll(self.seq, now, ack, want)), now, now)
        reply = decode_reply(raw)
        assert reply.follower == self.follower.follower_id
        assert reply.poll_seq == self.seq
        return reply.fragment

    def frag(self, now: float, ack: tuple[int, int] | None = None,
             want: Want = "next") -> FragmentData:
        frag = self.poll(now, ack, want)
        assert frag is not None
        return frag


def test_nothing_new_then_the_freshest_update_with_its_time_stamp() -> None:
    d = Driver(Follower("f", FollowerConfig()))
    assert d.poll(0.0) is None
    d.follower.offer(b"old", 1.0)
    d.follower.offer(b"new", 2.0)
    frag = d.frag(3.0)
    assert (frag.data, frag.generated_at, frag.update_seq) == (b"new", 2.0, 2)
    assert d.poll(4.0, ack=(2, 0)) is None  # acked, nothing newer: nothing new
    assert d.follower.polls == 3


def test_reply_echoes_the_follower_receive_and_send_times() -> None:
    f = Follower("f")
    reply = decode_reply(f.on_poll(encode_poll(Poll(7, 1.0, None)), 11.0, 11.5))
    assert (reply.poll_seq, reply.received_at, reply.sent_at) == (7, 11.0, 11.5)


def test_fragments_advance_only_on_ack_and_are_resent_until_acked() -> None:
    d = Driver(Follower("f", FollowerConfig(fragment_size=SMALL)))
    payload = bytes(range(25))
    d.follower.offer(payload, 1.0)
    f0 = d.frag(2.0)
    assert (f0.index, f0.count, f0.data) == (0, 3, payload[:10])
    assert d.frag(2.1) == f0  # reply lost, no ack: resent
    f1 = d.frag(2.2, ack=(1, 0))
    assert f1.index == 1
    assert d.frag(2.3, ack=(1, 0)) == f1  # old ack again: resent
    f2 = d.frag(2.4, ack=(1, 1))
    assert (f2.index, f2.data) == (2, payload[20:])
    assert d.poll(2.5, ack=(1, 2)) is None


def test_abandon_a_half_sent_update_only_when_the_waiting_one_is_much_fresher() -> None:
    d = Driver(Follower("f", FollowerConfig(fragment_size=SMALL, abandon_after=1.0)))
    d.follower.offer(bytes(30), 0.0)
    d.frag(0.1)
    d.follower.offer(bytes(30), 0.9)  # 0.9 s fresher: keep going
    assert d.frag(0.2, ack=(1, 0)).update_seq == 1
    assert d.follower.abandoned == 0
    d.follower.offer(bytes(30), 1.5)  # 1.5 s fresher than the one being sent: switch
    frag = d.frag(0.3, ack=(1, 1))
    assert (frag.update_seq, frag.index, frag.generated_at) == (3, 0, 1.5)
    assert d.follower.abandoned == 1


def test_an_update_with_nothing_acknowledged_gives_way_to_a_fresher_one() -> None:
    d = Driver(Follower("f", FollowerConfig(fragment_size=SMALL, abandon_after=100.0)))
    d.follower.offer(bytes(30), 0.0)
    assert d.frag(0.1).update_seq == 1
    d.follower.offer(bytes(30), 0.05)
    assert d.frag(0.2).update_seq == 2  # its first fragment never got through: switch


def test_fifo_never_abandons_and_sends_in_order() -> None:
    d = Driver(Follower("f", FollowerConfig(queue="fifo", capacity=4, fragment_size=SMALL)))
    for t in (0.0, 5.0, 10.0):
        d.follower.offer(bytes(15), t)
    seen = []
    ack = None
    for step in range(6):
        frag = d.frag(20.0 + step, ack=ack)
        seen.append((frag.update_seq, frag.index))
        ack = (frag.update_seq, frag.index)
    assert seen == [(1, 0), (1, 1), (2, 0), (2, 1), (3, 0), (3, 1)]
    assert d.follower.abandoned == 0


def test_fresh_request_drops_a_half_sent_update() -> None:
    d = Driver(Follower("f", FollowerConfig(fragment_size=SMALL)))
    d.follower.offer(bytes(30), 0.0)
    d.frag(0.1)
    d.frag(0.2, ack=(1, 0))
    d.follower.offer(b"fresh", 0.3)
    frag = d.frag(0.4, ack=(1, 1), want="fresh")
    assert (frag.update_seq, frag.data) == (2, b"fresh")
    assert d.follower.abandoned == 1


def test_fresh_request_still_resends_an_unacknowledged_freshest_update() -> None:
    """The leader asks "fresh" again when the reply to its last "fresh" poll was lost:
    the follower must not throw away the freshest update nobody has acknowledged."""
    d = Driver(Follower("f"))
    d.follower.offer(b"only", 1.0)
    first = d.frag(2.0, want="fresh")  # this reply is lost
    assert d.poll(3.0, want="fresh") == first


def test_offer_applies_rate_control_and_counts_drops() -> None:
    f = Follower("f", FollowerConfig(rate_hz=4.0))
    admitted = [f.offer(b"x", t) for t in (0.0, 0.125, 0.25, 0.375, 0.5)]
    assert admitted == [True, False, True, False, True]
    assert (f.offered, f.rate_dropped) == (5, 2)


def test_offer_reports_a_full_fifo() -> None:
    f = Follower("f", FollowerConfig(queue="fifo", capacity=1, drop="tail"))
    assert f.offer(b"a", 0.0)
    assert not f.offer(b"b", 0.1)


def test_offer_rejects_misuse() -> None:
    f = Follower("f", FollowerConfig(max_update_bytes=4))
    with pytest.raises(TypeError):
        f.offer("text", 0.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="max_update_bytes"):
        f.offer(b"12345", 0.0)
    assert f.offer(bytearray(b"1234"), 0.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        Follower("")


@pytest.mark.parametrize("garbage", [b"", b"\xc1", b"\x93\x01\x02\x03", encode_control(
    Control(1, 0.0, {}))])
def test_garbage_poll_raises_wire_error_and_is_not_counted(garbage: bytes) -> None:
    f = Follower("f")
    with pytest.raises(WireError):
        f.on_poll(garbage, 0.0, 0.0)
    assert f.polls == 0


def test_control_newer_wins_and_a_restarted_leader_is_obeyed() -> None:
    f = Follower("f")
    wp = [(1.0, 2.0, 3.0, 4.0)]
    assert f.on_control(encode_control(Control(5, 10.0, {"f": wp, "g": []}, 7)), 10.0) == wp
    assert f.on_control(encode_control(Control(5, 10.0, {"f": wp}, 7)), 10.0) is None  # again
    assert f.on_control(encode_control(Control(4, 10.0, {"f": [(0, 0, 0, 0)]}, 7)), 10.0) is None
    assert f.on_control(encode_control(Control(9, 9.5, {"f": [(0, 0, 0, 0)]}, 7)), 10.0) is None
    later = [(2.0, 0.0, 0.0, 1.0)]
    assert f.on_control(encode_control(Control(6, 10.0, {"f": later}, 7)), 10.0) == later
    restarted = [(3.0, 1.0, 1.0, 1.0)]  # new leader: seq back at 1, a new epoch
    assert f.on_control(encode_control(Control(1, 9.9, {"f": restarted}, 8)), 10.0) == restarted
    assert f.control.stale == 3


def test_control_without_an_entry_for_this_follower() -> None:
    f = Follower("f")
    assert f.on_control(encode_control(Control(1, 1.0, {"g": [(0, 0, 0, 0)]})), 1.0) is None
    with pytest.raises(WireError):
        f.on_control(encode_poll(Poll(1, 1.0, None)), 1.0)


@pytest.mark.parametrize("follower_id", ["f", "x" * 128, "x" * 129, "ü" * 128, "🛸" * 128],
                         ids=["short", "128-ascii", "129-ascii", "128-two-byte", "128-four-byte"])
def test_follower_id_is_refused_or_every_reply_fits_in_the_fragment_size(
    follower_id: str,
) -> None:
    """Either the follower refuses an id up front (ValueError: one the wire would reject),
    or every reply it sends decodes and stays within ``fragment_size``."""
    size = FRAGMENT_HEADER_BYTES + 100
    try:
        f = Follower(follower_id, FollowerConfig(fragment_size=size))
    except ValueError:
        with pytest.raises(WireError):
            decode_reply(encode_reply(Reply(follower_id, 1, 0.0, 0.0, None)))
        return
    f.offer(bytes(1000), 1.0)
    ack = None
    for seq in range(2**40, 2**40 + 10):  # a long-running leader: large poll numbers
        raw = f.on_poll(encode_poll(Poll(seq, 1.0, ack)), 1.5, 1.5)
        assert len(raw) <= size
        frag = decode_reply(raw).fragment
        assert frag is not None
        ack = (frag.update_seq, frag.index)
