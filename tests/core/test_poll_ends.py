"""A poll whose request is over (Zenoh's get: no queryable, or every replier done) ends
at once, and one timeout among many answers is no verdict on a follower."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.core import Delivered, LeaderConfig, Rejected, TimedOut, drain
from wiswarm_zenoh.core.leader import END_GRACE

from .drive import answer, exchange, on_reply, poll
from .test_leader import _setup


def test_the_end_of_a_get_with_no_valid_reply_ends_its_poll_now() -> None:
    leader, followers = _setup("a", "b")
    exchange(leader, followers, 0.0)
    request = poll(leader, 1.0)
    leader.receive_end(request.follower, request.poll_seq, 1.0001)
    assert leader.get_timer() == pytest.approx(1.0001 + END_GRACE)  # not the deadline
    leader.handle_timer(1.0001 + END_GRACE)
    assert drain(leader)[0] == TimedOut(request.follower, request.poll_seq)
    assert poll(leader, 1.0022).sent_at == 1.0022  # the channel is free


def test_a_refused_reply_keeps_the_poll_open_only_until_its_get_is_over() -> None:
    leader, followers = _setup("a")
    exchange(leader, followers, 0.0)
    request = poll(leader, 1.0)
    leader.receive_reply("a", b"\x93garbage", 1.001)  # a rogue queryable on its key
    assert [type(e) for e in drain(leader)] == [Rejected]
    assert leader.get_timer() == request.deadline  # the genuine answer may still come
    leader.receive_end("a", request.poll_seq, 1.002)  # no: the get is over
    leader.handle_timer(leader.get_timer() or 0.0)
    assert drain(leader) == [TimedOut("a", request.poll_seq)]
    assert leader.stats("a", 1.002).timeouts == 1


def test_a_reply_that_comes_just_after_its_gets_end_is_taken() -> None:
    """Over two paths (a peer's own link and the router's) the get's end can overtake
    the reply: the poll waits ``END_GRACE`` for it."""
    leader, followers = _setup("a")
    followers["a"].offer(b"frame", 0.0)
    request = poll(leader, 0.0)
    leader.receive_end("a", request.poll_seq, 0.001)
    assert [type(e) for e in answer(leader, followers, request, 0.0, latency=0.0006)] == [
        Delivered]


def test_the_end_of_a_poll_already_answered_or_timed_out_changes_nothing() -> None:
    leader, followers = _setup("a")
    followers["a"].offer(b"frame", 0.0)
    request = poll(leader, 0.0)
    assert [type(e) for e in answer(leader, followers, request, 0.0)] == [Delivered]
    leader.receive_end("a", request.poll_seq, 0.003)  # the final after the answer
    assert drain(leader) == []
    late = poll(leader, 1.0)
    leader.handle_timer(late.deadline)
    drain(leader)
    leader.receive_end("a", late.poll_seq, 1.5)  # the get closed at the ceiling
    assert drain(leader) == []
    assert leader.stats("a", 2.0).timeouts == 1
    raw = followers["a"].on_poll(late.payload, 1.6, 1.6)  # a late reply overtaken by its
    assert on_reply(leader, "a", raw, 1.7) == []  # get's end still teaches the link's pace


def test_one_timeout_among_many_answers_costs_no_price_once_it_answers_again() -> None:
    """Priced by p over W polls, one timeout kept a follower at about 0.6 of its weight
    for its next W polls (tens of seconds in a swarm of a thousand); with one loss of
    the window forgiven, its next answer restores its full weight. (Its sources' phase
    aside: a poll held for it would not be where ``exchange`` sends it.)"""
    leader, followers = _setup("a", "b", config=LeaderConfig(window=20, pace_sources=False))
    t = 0.0
    for _ in range(60):
        for f in followers.values():
            f.offer(b"frame", t)
        exchange(leader, followers, t)
        t += 0.002
    request = poll(leader, t)
    leader.handle_timer(request.deadline)
    drain(leader)
    i = leader.table.index(request.follower)
    assert leader.table.w[i] < 0.5  # while the miss is the last word: priced down
    t = request.deadline
    while (again := poll(leader, t)).follower != request.follower:
        answer(leader, followers, again, t)
        t += 0.002
    answer(leader, followers, again, t)
    assert leader.stats(request.follower, t).p_hat == pytest.approx(0.95)
    assert leader.table.w[i] == pytest.approx(1.0)  # the weight, unpriced
