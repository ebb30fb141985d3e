"""The two-step reply (``accept_reply`` then ``settle``): the scheduler sees a fresh
update at once, the checksum and the delivery come after, and nothing is lost between."""

from __future__ import annotations

import dataclasses

import pytest

from wiswarm_zenoh.core import Delivered, Follower, Leader, LeaderConfig, Rejected
from wiswarm_zenoh.core.wire import decode_reply, encode_reply

from .drive import poll, poll_message

FRAME = b"frame" * 100


def _setup() -> tuple[Leader, dict[str, Follower]]:
    leader = Leader(LeaderConfig(policy="max-age"))
    followers = {fid: Follower(fid) for fid in ("a", "b")}
    for (fid, follower), made_at in zip(followers.items(), (0.5, 0.25), strict=True):
        leader.add_follower(fid, 0.0)
        follower.offer(FRAME, made_at)
    return leader, followers


def _answer(followers: dict[str, Follower], fid: str, payload: bytes, at: float) -> bytes:
    return followers[fid].on_poll(payload, at, at)


def test_an_accepted_update_counts_for_the_next_choice_before_it_is_settled() -> None:
    leader, followers = _setup()
    first = poll(leader, 1.0)
    raw = _answer(followers, first.follower, first.payload, 1.001)
    assert leader.accept_reply(first.follower, raw, 1.002) == []
    assert leader.stats(first.follower, 1.002).deliveries == 0  # not settled yet
    second = poll(leader, 1.002)
    assert second.follower != first.follower  # the first is fresh already: max-age moves on
    assert poll_message(second).seq == first.poll_seq + 1
    events = leader.settle()
    assert len(events) == 1 and isinstance(events[0], Delivered)
    assert (events[0].follower, events[0].payload) == (first.follower, FRAME)
    assert leader.stats(first.follower, 1.002).deliveries == 1
    assert leader.settle() == []


def test_a_checksum_failure_at_settle_withdraws_the_freshness_and_asks_afresh() -> None:
    leader, followers = _setup()
    first = poll(leader, 1.0)
    fid = first.follower
    assert fid == "a"  # its frame is from 0.5, b's from 0.25
    reply = decode_reply(_answer(followers, fid, first.payload, 1.001))
    assert reply.fragment is not None
    damaged = dataclasses.replace(reply.fragment, data=b"X" * len(reply.fragment.data))
    leader.accept_reply(fid, encode_reply(dataclasses.replace(reply, fragment=damaged)), 1.002)
    other = poll(leader, 1.002)
    assert other.follower != fid
    events = leader.settle()
    assert len(events) == 1 and isinstance(events[0], Rejected)
    assert "checksum" in events[0].reason
    assert leader.stats(fid, 1.002).errors == 1
    leader.on_reply(other.follower, _answer(followers, other.follower, other.payload, 1.003),
                    1.004)
    again = poll(leader, 1.004)
    assert again.follower == fid  # aged from 0 again, not from its rejected frame at 0.5
    assert poll_message(again).want == "fresh"


def test_accepting_the_next_reply_settles_the_one_before_first() -> None:
    leader, followers = _setup()
    first = poll(leader, 1.0)
    leader.accept_reply(first.follower, _answer(followers, first.follower, first.payload,
                                                1.001), 1.002)
    second = poll(leader, 1.002)
    events = leader.accept_reply(
        second.follower, _answer(followers, second.follower, second.payload, 1.003), 1.004)
    assert [(type(e), e.follower) for e in events] == [(Delivered, first.follower)]
    events = leader.settle()
    assert [(type(e), e.follower) for e in events] == [(Delivered, second.follower)]


def test_a_follower_removed_before_settling_is_forgotten_with_its_reply() -> None:
    leader, followers = _setup()
    first = poll(leader, 1.0)
    leader.accept_reply(first.follower, _answer(followers, first.follower, first.payload,
                                                1.001), 1.002)
    leader.remove_follower(first.follower)
    assert leader.settle() == []
    assert leader.followers == [fid for fid in followers if fid != first.follower]


def test_a_follower_restarting_before_its_update_is_settled_changes_nothing_of_it() -> None:
    """The update's time-stamp is put on the leader's clock when it comes, with the clock
    estimate of the process that sent it, not of the one that replaced it."""
    leader = Leader()
    follower = Follower("a")
    leader.add_follower("a", 0.0)
    offset = 5.0  # the follower's clock is 5 s ahead
    for t in (1.0, 1.1, 1.2):
        follower.offer(FRAME, t - 0.1 + offset)
        request = poll(leader, t)
        raw = _answer({"a": follower}, "a", request.payload, t + 0.001 + offset)
        leader.accept_reply("a", raw, t + 0.002)
        events = leader.settle()
        assert [type(e) for e in events] == [Delivered]
        assert events[0].generated_at == pytest.approx(t - 0.1, abs=1e-3)
    follower.offer(FRAME, 1.5 + offset)
    request = poll(leader, 2.0)
    leader.accept_reply("a", _answer({"a": follower}, "a", request.payload, 2.001 + offset),
                        2.002)
    leader.add_follower("a", 2.002)  # it restarted: its clock estimate starts over
    events = leader.settle()
    assert [type(e) for e in events] == [Delivered]
    assert events[0].generated_at == pytest.approx(1.5, abs=1e-3)
    restarted = Follower("a")  # the new process's clock is right
    restarted.offer(FRAME, 2.9)
    request = poll(leader, 3.0)  # a slower round trip than the one before the restart
    events = leader.on_reply("a", _answer({"a": restarted}, "a", request.payload, 3.001),
                             3.004)
    assert [type(e) for e in events] == [Delivered]
    assert events[0].generated_at == pytest.approx(2.9, abs=1e-3)  # no sample of the old one
