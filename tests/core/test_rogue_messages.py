"""One bad message from a stranger: control with forged leader times, a second poller,
replies forged on a follower's key. Each case as a user met it, and what holds now."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from wiswarm_zenoh.core import (
    Delivered,
    Follower,
    FollowerConfig,
    Leader,
    LeaderConfig,
    Rejected,
    Stale,
    TimedOut,
    WireError,
)
from wiswarm_zenoh.core.fragments import Reassembler
from wiswarm_zenoh.core.wire import (
    Control,
    FragmentData,
    Poll,
    Reply,
    checksum,
    decode_reply,
    encode_control,
    encode_poll,
    encode_reply,
)

from .drive import on_reply, on_timer, poll

EPOCH = 1_700_000_000_000_000  # a leader started at that time (microseconds)
WP = [(1.0, 2.0, 3.0, 4.0)]
ROGUE_WP = [(9.0, 99.0, 99.0, 99.0)]


def _control(seq: int, lt: float, waypoints: list[tuple[float, float, float, float]],
             epoch: int = EPOCH) -> bytes:
    return encode_control(Control(seq, lt, {"f": waypoints}, epoch))


def _polled(follower: Follower, leader_time: float, at: float, epoch: int = EPOCH,
            ack: tuple[int, int] | None = None, seq: int = 1) -> Reply:
    return decode_reply(follower.on_poll(encode_poll(Poll(seq, leader_time, ack, "next", epoch)),
                                         at, at))


# --- control ---

def test_far_future_control_is_refused_and_never_blocks_the_leader() -> None:
    """The case reported: one message stamped far ahead took the follower and then made it
    ignore every genuine message as older."""
    f = Follower("f")
    _polled(f, leader_time=500.0, at=100.0)  # the leader's clock runs 400 s ahead
    with pytest.raises(WireError, match=r"stamped \+3600\.000 s off its leader's clock"):
        f.on_control(_control(99, 500.5 + 3600, ROGUE_WP), 100.5)
    assert f.control.rejected == 1
    assert f.on_control(_control(1, 500.6, WP), 100.6) == WP


def test_replays_and_far_past_control_are_refused() -> None:
    f = Follower("f")
    _polled(f, leader_time=10.0, at=10.0)
    old = _control(1, 10.0, ROGUE_WP)
    assert f.on_control(old, 10.0) == ROGUE_WP
    assert f.on_control(_control(2, 10.2, WP), 10.2) == WP
    assert f.on_control(old, 10.3) is None  # a replay within the window: not newer
    with pytest.raises(WireError, match=r"-2\.000 s off"):
        f.on_control(old, 12.0)  # beyond it: refused outright
    fresh = Follower("f")  # a restarted follower knows nothing yet: its own clock judges
    with pytest.raises(WireError, match="no poll of that epoch yet"):
        fresh.on_control(old, 12.0)


def test_a_leader_whose_clock_is_off_is_obeyed_from_its_first_poll() -> None:
    f = Follower("f")
    with pytest.raises(WireError, match="no poll of that epoch yet"):
        f.on_control(_control(1, 5000.0, WP), 10.0)
    _polled(f, leader_time=5000.0, at=10.0)
    assert f.on_control(_control(2, 5000.1, WP), 10.1) == WP


def test_a_restarted_leader_is_obeyed_before_and_after_it_polls() -> None:
    f = Follower("f")
    _polled(f, leader_time=10.0, at=10.0)
    assert f.on_control(_control(900, 10.0, ROGUE_WP), 10.0) == ROGUE_WP
    # The new process: a larger epoch, its seq back at 1, on a clock as good as the old.
    assert f.on_control(_control(1, 11.0, WP, EPOCH + 5), 11.0) == WP
    _polled(f, leader_time=11.5, at=11.5, epoch=EPOCH + 5)
    assert f.on_control(_control(2, 11.6, ROGUE_WP, EPOCH + 5), 11.6) == ROGUE_WP


def test_a_forged_poll_moves_the_leaders_clock_only_until_its_next_poll() -> None:
    f = Follower("f")
    _polled(f, leader_time=10.0, at=10.0)
    _polled(f, leader_time=10.0 + 3600, at=10.1)  # a stranger's get with the leader's epoch
    with pytest.raises(WireError):
        f.on_control(_control(1, 10.2, WP), 10.2)
    _polled(f, leader_time=10.3, at=10.3)
    assert f.on_control(_control(2, 10.3, WP), 10.3) == WP


def test_another_epochs_plausible_control_holds_only_until_the_leaders_next() -> None:
    f = Follower("f")
    _polled(f, leader_time=10.0, at=10.0)
    assert f.on_control(_control(1, 10.0, WP), 10.0) == WP
    newer = EPOCH + 1  # a leader that has not polled yet: judged on the follower's clock
    assert f.on_control(_control(2**63 - 1, 10.05, ROGUE_WP, epoch=newer), 10.05) == ROGUE_WP
    assert f.on_control(_control(2, 10.1, WP), 10.1) == WP


def test_control_of_an_epoch_older_than_the_polling_leader_is_ignored() -> None:
    """A leader taken over from (or a stranger posing as one) no longer steers while
    the newer one polls; once that one is quiet for longer than ``poller_expiry``, the
    older epoch is heard again (it may be the only leader left)."""
    f = Follower("f")
    _polled(f, leader_time=10.0, at=10.0, epoch=EPOCH - 1)
    _polled(f, leader_time=10.0, at=10.0)  # a newer leader took over: not yet obeyed
    assert f.on_control(_control(1, 10.0, ROGUE_WP, epoch=EPOCH - 1), 10.0) == ROGUE_WP
    assert f.on_control(_control(1, 10.0, WP), 10.0) == WP
    assert f.on_control(_control(2**63 - 1, 10.05, ROGUE_WP, epoch=EPOCH - 1), 10.05) is None
    assert f.control.stale == 1
    quiet = 10.0 + f.config.poller_expiry + 0.01
    assert f.on_control(_control(5, quiet, ROGUE_WP, epoch=EPOCH - 1), quiet) == ROGUE_WP


# --- a second poller ---

def test_a_second_poller_gets_its_own_transfer_and_takes_nothing_from_the_leader() -> None:
    config = FollowerConfig(fragment_size=1000)  # 1500 bytes: 3 fragments of 680 bytes
    f = Follower("f", config)
    first, second = bytes([1]) * 1500, bytes([2]) * 1500
    f.offer(first, 1.0)
    reassembler = Reassembler(16, 10_000)
    reply = _polled(f, 1.0, 1.0, seq=1)  # the leader: fragment 0 of the first frame
    assert reply.fragment is not None and reply.fragment.count == 3
    assert reassembler.add(reply.fragment) is None
    ack = (reply.fragment.update_seq, 0)
    # A stranger polls with an older epoch, acks garbage, asks for fresh updates.
    for k in range(3):
        stray = _polled(f, 1.0, 1.01, epoch=3, ack=(99, k), seq=50 + k)
        assert stray.fragment is not None and stray.fragment.update_seq == 1
    f.offer(second, 1.02)
    stray = _polled(f, 1.0, 1.03, epoch=3, seq=60)
    assert stray.fragment is not None and stray.fragment.update_seq == 2  # the freshest
    whole = None
    for seq in range(2, 10):
        reply = _polled(f, 1.1, 1.1, ack=ack, seq=seq)
        assert reply.fragment is not None
        if reply.fragment.update_seq != 1:
            break
        whole = reassembler.add(reply.fragment)
        ack = (1, reply.fragment.index)
    assert whole == first  # the leader's transfer went on as if nobody else had polled
    assert reply.fragment.update_seq == 2  # and the second frame is still its to take
    assert f.queue.peek() is None


def test_a_higher_epoch_takes_the_queue_and_the_update_in_progress() -> None:
    f = Follower("f", FollowerConfig(fragment_size=1000))
    f.offer(bytes(1500), 1.0)
    old = _polled(f, 1.0, 1.0)
    assert old.fragment is not None and old.fragment.index == 0
    new = _polled(f, 1.1, 1.1, epoch=EPOCH + 1)
    assert new.fragment is not None and (new.fragment.update_seq, new.fragment.index) == (1, 0)
    assert f.pollers.main is not None and f.pollers.main.epoch == EPOCH + 1
    f.offer(bytes(10), 1.2)
    again = _polled(f, 1.2, 1.2, ack=(1, 0), seq=2)  # the old leader, now secondary
    assert again.fragment is not None and again.fragment.update_seq == 1
    assert f.queue.peek() is not None  # a secondary leaves the queue to the main poller
    assert f.pollers.main.epoch == EPOCH + 1
    late = _polled(f, 1.2, 1.2 + FollowerConfig().poller_expiry + 0.1, seq=3)
    assert f.pollers.main.epoch == EPOCH  # the new one went quiet: the old one is main again
    assert late.fragment is not None


# --- replies forged on a follower's key ---

def _leader_with(follower: str = "f") -> Leader:
    leader = Leader(LeaderConfig(), epoch=EPOCH)
    leader.add_follower(follower, 0.0)
    return leader


def _forged(poll_seq: int, rt: float, st: float, gen: float, seq: int = 1,
            sender: str = "f") -> bytes:
    frag = FragmentData(seq, gen, 0, 1, 5, checksum(b"rogue"), b"rogue")
    return encode_reply(Reply(sender, poll_seq, rt, st, frag))


def _genuine(follower: Follower, payload: bytes, gen: float, request_payload: bytes,
             at: float) -> bytes:
    follower.offer(payload, gen)
    return follower.on_poll(request_payload, at, at)


def test_a_reply_stamped_an_hour_ahead_is_refused_and_cuts_nobody_off() -> None:
    """The case reported: a queryable on f's key answered with updates stamped an hour
    ahead; they were delivered with an age of -3600 s, and f's real updates were stale
    for an hour after."""
    leader, f = _leader_with(), Follower("f")
    for k in range(3):  # the clock estimate has samples
        request = poll(leader, 1.0 + k)
        raw = _genuine(f, b"frame", 0.999 + k, request.payload, 1.001 + k)
        assert isinstance(on_reply(leader, "f", raw, 1.002 + k)[0], Delivered)
    request = poll(leader, 10.0)
    for forged in (_forged(request.poll_seq, 10.001, 10.001, 3610.0),
                   _forged(request.poll_seq, 3610.001, 3610.001, 3610.0)):
        events = on_reply(leader, "f", forged, 10.002)
        assert [type(e) for e in events] == [Rejected]
        assert leader.in_flight == "f"  # still waiting for f's own answer
    raw = _genuine(f, b"frame", 9.999, request.payload, 10.001)
    events = on_reply(leader, "f", raw, 10.002)
    assert isinstance(events[0], Delivered) and events[0].age == pytest.approx(0.003)
    for k in range(3):
        request = poll(leader, 11.0 + k)
        raw = _genuine(f, b"frame", 10.999 + k, request.payload, 11.001 + k)
        assert isinstance(on_reply(leader, "f", raw, 11.002 + k)[0], Delivered)
    assert leader.stats("f", 13.002).aoi_s == pytest.approx(0.003)


def test_a_forger_who_answers_a_new_follower_first_holds_its_clock_only_for_a_while() -> None:
    """The first answer anchors a follower's clock: a forged one (an hour ahead, stamps
    consistent) is delivered as if now. The follower's own replies then disagree with it:
    refused for ``clock_samples`` polls, then the estimate re-anchors, and its updates
    are delivered again (the forged stamp counted as 'now', so none is held back)."""
    config = LeaderConfig(clock_samples=4)
    leader, f = Leader(config, epoch=EPOCH), Follower("f")
    leader.add_follower("f", 0.0)
    request = poll(leader, 1.0)
    events = on_reply(leader, "f", _forged(request.poll_seq, 3601.001, 3601.001, 3601.0), 1.002)
    assert isinstance(events[0], Delivered) and events[0].age == pytest.approx(0.002)
    refused = 0
    for k in range(1, 10):
        now = 1.0 + k
        request = poll(leader, now)
        raw = _genuine(f, b"frame", now - 0.001, request.payload, now + 0.001)
        events = on_reply(leader, "f", raw, now + 0.002)
        if isinstance(events[0], Delivered):
            break
        assert isinstance(events[0], Rejected)
        refused += 1
        assert isinstance(on_timer(leader, now + 0.3)[0], TimedOut)
    assert refused == config.clock_samples - 1
    assert leader.stats("f", now + 0.002).aoi_s == pytest.approx(0.003)


@pytest.mark.parametrize(("forged", "reason"), [
    (lambda seq: _forged(seq, 2.001, 2.001, 2.5), "after the reply carrying it was sent"),
    (lambda seq: _forged(seq, 2.001, 1.9, 1.0), "out of order"),
    (lambda seq: _forged(seq, 2.001, 2.001, 1.0, sender="g"), "claims to come from"),
])
def test_implausible_replies_leave_the_poll_to_the_followers_own(
    forged: Callable[[int], bytes], reason: str
) -> None:
    leader, f = _leader_with(), Follower("f")
    request = poll(leader, 2.0)
    events = on_reply(leader, "f", forged(request.poll_seq), 2.002)
    assert isinstance(events[0], Rejected) and reason in events[0].reason
    assert isinstance(on_reply(leader, "f", _forged(2**63 - 1, 2.001, 2.001, 1.0), 2.002)[0],
                      Stale)
    raw = _genuine(f, b"frame", 1.999, request.payload, 2.001)
    assert isinstance(on_reply(leader, "f", raw, 2.002)[0], Delivered)


def test_a_stamp_ahead_within_the_tolerance_is_delivered_as_now_never_with_negative_age(
) -> None:
    leader = _leader_with()
    request = poll(leader, 2.0)
    # Stamped 4.5 ms after the reply left: within the slack for clock reads, and ahead of
    # the leader's clock once mapped onto it.
    events = on_reply(leader, "f", _forged(request.poll_seq, 2.003, 2.0035, 2.008), 2.002)
    delivered = events[0]
    assert isinstance(delivered, Delivered)
    assert delivered.age == 0.0 and delivered.generated_at == 2.002
