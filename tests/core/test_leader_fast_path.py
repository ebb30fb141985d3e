"""A reply's work is all done when it comes in; the next poll goes out before its
events are handed on, to the follower the usual path would pick: with one poll out, the
pick made while the reply was on its way (by the ``next_poll`` that found no room),
weighed against the polled follower's new index only. Nothing is lost between."""

from __future__ import annotations

import dataclasses
import random
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wiswarm_zenoh.core import (
    Delivered,
    Event,
    Follower,
    FollowerConfig,
    Leader,
    LeaderConfig,
    PollRequest,
    Rejected,
    Silent,
    TimedOut,
    drain,
)
from wiswarm_zenoh.core.peers import PLAIN_LOOPS_MAX
from wiswarm_zenoh.core.wire import FragmentData, Reply, decode_reply, encode_reply

from .drive import on_reply, poll, poll_message

FRAME = b"frame" * 100
LATENCY = 0.001


def _swarm(n: int, config: LeaderConfig | None = None) -> tuple[Leader, dict[str, Follower]]:
    leader = Leader(config or LeaderConfig())
    followers = {}
    for i in range(n):
        fid = f"uav{i}"
        leader.add_follower(fid, 0.0)
        followers[fid] = Follower(fid, FollowerConfig(fragment_size=4096))
    return leader, followers


def _answer(followers: dict[str, Follower], request: PollRequest) -> bytes:
    at = request.sent_at + LATENCY
    return followers[request.follower].on_poll(request.payload, at, at)


def _usual(leader: Leader, request: PollRequest, raw: bytes,
           now: float) -> tuple[PollRequest, list[Event]]:
    """The reply's work all done before choosing: no pick is made, none is taken."""
    leader.receive_reply(request.follower, raw, now)
    events = drain(leader)
    return poll(leader, now), events


def _fast(leader: Leader, request: PollRequest, raw: bytes,
          now: float) -> tuple[PollRequest, list[Event]]:
    """As a shell: the next polls until none (the last call makes the pick for after
    the one out), then the events."""
    leader.receive_reply(request.follower, raw, now)
    following = poll(leader, now)
    assert leader.next_poll(now) is None
    return following, drain(leader)


def _early(leader: Leader, request: PollRequest, raw: bytes,
           now: float) -> tuple[PollRequest, list[Event]]:
    """As a shell that sends the next poll before the reply is judged where it can."""
    following = leader.poll_on_answer(request.follower, raw, now)
    leader.receive_reply(request.follower, raw, now)
    if following is None:
        following = poll(leader, now)
    assert leader.next_poll(now) is None
    return following, drain(leader)


def _delivered(events: list[Event]) -> list[tuple[str, bytes, float]]:
    return [(e.follower, e.payload, e.generated_at) for e in events if isinstance(e, Delivered)]


# Random swarms (followers, their weights, which of them has a frame when, made how long
# before the poll) for the property tests of both fast paths
SWARMS = given(
    n=st.integers(2, 6),
    weights=st.lists(st.floats(0.1, 10.0), min_size=6, max_size=6),
    offers=st.lists(st.tuples(st.integers(0, 5), st.floats(0.0, 0.002)), max_size=60),
)
RUNS = settings(max_examples=60, deadline=None)


def _compare_paths(n: int, weights: list[float], offers: list[tuple[int, float]],
                   path: Callable[..., tuple[PollRequest, list[Event]]] = _fast) -> Leader:
    """Two swarms fed the same frames: one leader takes every reply the usual way, the
    other on the fast ``path`` where it can. Both must poll the same followers in the
    same order and deliver the same updates. Returns the fast one."""
    config = LeaderConfig(pace_sources=False)  # polls that find nothing new stay in
    usual, usual_followers = _swarm(n, config)
    fast, fast_followers = _swarm(n, config)
    for leader in (usual, fast):
        for i, weight in enumerate(weights[:n]):
            leader.observe_urgency(f"uav{i}", weight)
    usual_request, fast_request = poll(usual, 0.0), poll(fast, 0.0)
    assert fast.next_poll(0.0) is None  # the pick for after the first poll
    usual_events: list[Event] = []
    fast_events: list[Event] = []
    for step, (who, made_before) in enumerate(offers):
        for followers in (usual_followers, fast_followers):
            followers[f"uav{who % n}"].offer(FRAME + bytes([step % 256]),
                                             usual_request.sent_at - made_before)
        arrives = fast_request.sent_at + fast.slot  # when the pick expected it: same ages
        fast_request, events = path(fast, fast_request, _answer(fast_followers, fast_request),
                                     arrives)
        fast_events += events
        usual_request, events = _usual(usual, usual_request,
                                       _answer(usual_followers, usual_request), arrives)
        usual_events += events
        assert fast_request.follower == usual_request.follower, step
    assert _delivered(fast_events) == _delivered(usual_events)
    assert usual.fast_polls == 0
    return fast


@RUNS
@SWARMS
def test_the_fast_path_picks_what_the_usual_path_picks(
        n: int, weights: list[float], offers: list[tuple[int, float]]) -> None:
    # mostly fast, after two polls whose picks are made before any slot was measured
    assert _compare_paths(n, weights, offers).fast_polls >= (len(offers) - 2) // 2


@RUNS
@SWARMS
def test_polls_sent_before_the_reply_is_judged_are_the_usual_picks(
        n: int, weights: list[float], offers: list[tuple[int, float]]) -> None:
    early = _compare_paths(n, weights, offers, _early)
    assert early.early_polls <= early.fast_polls


@pytest.mark.parametrize("path", [_fast, _early])
def test_the_fast_path_picks_what_the_usual_path_picks_among_many(
        path: Callable[..., tuple[PollRequest, list[Event]]]) -> None:
    n = PLAIN_LOOPS_MAX + 6  # numpy's side of prepare
    rng = random.Random(3)
    weights = [rng.uniform(0.1, 10.0) for _ in range(n)]
    offers = [(rng.randrange(n), rng.uniform(0.0, 0.002)) for _ in range(300)]
    fast = _compare_paths(n, weights, offers, path)
    assert fast.fast_polls >= 150
    if path is _early:  # each answer brings a whole update: each next poll goes first
        assert fast.early_polls >= 150


def _picked_exchange(n: int = 3) -> tuple[Leader, dict[str, Follower], PollRequest, bytes]:
    """A poll out, the pick for after it made, its answer."""
    leader, followers = _swarm(n)
    for follower in followers.values():
        follower.offer(FRAME, 0.005)
    request = poll(leader, 0.01)
    assert leader.next_poll(0.01) is None
    assert drain(leader) == []
    return leader, followers, request, _answer(followers, request)


def test_a_reply_is_delivered_after_the_next_poll_and_counted() -> None:
    leader, _, request, raw = _picked_exchange()
    assert request.follower == "uav0"  # all equally old: the first joined
    leader.receive_reply("uav0", raw, 0.012)
    following = poll(leader, 0.012)
    assert following.follower != "uav0" and leader.fast_polls == 1
    assert leader.in_flight == following.follower
    assert _delivered(drain(leader)) == [("uav0", FRAME, 0.005)]
    stats = leader.stats("uav0", 0.012)
    assert (stats.deliveries, stats.polls, stats.timeouts) == (1, 1, 0)
    assert drain(leader) == []


def test_a_checksum_failure_leaves_the_follower_as_old_and_the_pick_untaken() -> None:
    leader, _, request, raw = _picked_exchange()
    reply = decode_reply(raw)
    assert reply.fragment is not None
    damaged = dataclasses.replace(reply.fragment, data=b"X" * len(reply.fragment.data))
    leader.receive_reply(request.follower,
                         encode_reply(dataclasses.replace(reply, fragment=damaged)), 0.012)
    assert poll(leader, 0.012).follower == request.follower  # still the oldest
    assert leader.fast_polls == 0
    events = drain(leader)
    assert len(events) == 1 and isinstance(events[0], Rejected)
    assert leader.stats(request.follower, 0.012).deliveries == 0


def _declines(leader: Leader, request: PollRequest, raw: bytes, now: float = 0.012) -> None:
    """The reply ends the poll, and the next is chosen the usual way."""
    leader.receive_reply(request.follower, raw, now)
    assert leader.in_flight is None
    poll(leader, now)
    assert leader.fast_polls == 0


def test_no_pick_is_taken_when_the_swarm_changed_or_there_is_nobody_else() -> None:
    leader, _, request, raw = _picked_exchange()
    leader.observe_urgency("uav1", 5.0)  # a new weight: the pick may be another now
    _declines(leader, request, raw)
    leader, _, request, raw = _picked_exchange()
    leader.add_follower("uav9", 0.005)
    _declines(leader, request, raw)
    leader, _, request, raw = _picked_exchange(n=1)  # nobody else to pick
    _declines(leader, request, raw)


def test_no_pick_is_taken_for_a_late_reply() -> None:
    leader, _, request, raw = _picked_exchange()
    _declines(leader, request, raw, now=request.sent_at + 2 * leader.slot + 0.001)


def test_no_pick_is_made_for_a_policy_without_an_index() -> None:
    leader, followers = _swarm(3, LeaderConfig(policy="round-robin"))
    request = poll(leader, 0.01)
    assert leader.next_poll(0.01) is None
    _declines(leader, request, _answer(followers, request))


def test_bad_stale_or_foreign_replies_leave_the_poll_out_and_the_pick_standing() -> None:
    leader, _, request, raw = _picked_exchange()
    for data, sender in ((b"\x00garbage", request.follower), (raw, "uav1"),
                         (encode_reply(dataclasses.replace(decode_reply(raw), poll_seq=7)),
                          request.follower)):
        leader.receive_reply(sender, data, 0.012)
        assert leader.in_flight == request.follower
        assert leader.next_poll(0.012) is None
        drain(leader)
    leader.receive_reply(request.follower, raw, 0.012)
    poll(leader, 0.012)
    assert leader.fast_polls == 1  # all as before


def test_no_pick_is_taken_for_a_fragment_of_a_larger_update() -> None:
    leader, followers = _swarm(3)
    followers["uav0"].offer(bytes(10_000), 0.0)  # three fragments of 4096 bytes
    request = poll(leader, 0.01)
    assert leader.next_poll(0.01) is None
    _declines(leader, request, _answer(followers, request))


def test_a_follower_whose_answer_leaves_it_oldest_keeps_its_turn() -> None:
    leader, _ = _swarm(2)
    leader.observe_urgency("uav0", 10.0)  # the heavier: polled first
    request = poll(leader, 10.0)
    assert request.follower == "uav0"
    assert leader.next_poll(10.0) is None
    # Its update is older than anything the leader has seen (a backlog): still first.
    old = FragmentData(1, -100.0, 0, 1, len(FRAME), 0, FRAME)
    raw = encode_reply(Reply(request.follower, request.poll_seq, 10.001, 10.001, old))
    leader.receive_reply(request.follower, raw, 10.002)
    assert poll(leader, 10.002).follower == "uav0" and leader.fast_polls == 0


# --- the reply's work and its events: the next poll between them ---


def _two(made: tuple[float, float] = (0.5, 0.25)) -> tuple[Leader, dict[str, Follower]]:
    leader = Leader(LeaderConfig(policy="max-age"))
    followers = {fid: Follower(fid) for fid in ("a", "b")}
    for (fid, follower), made_at in zip(followers.items(), made, strict=True):
        leader.add_follower(fid, 0.0)
        follower.offer(FRAME, made_at)
    return leader, followers


def _reply(followers: dict[str, Follower], request: PollRequest, at: float) -> bytes:
    return followers[request.follower].on_poll(request.payload, at, at)


def test_an_update_taken_counts_for_the_next_choice() -> None:
    leader, followers = _two()
    first = poll(leader, 1.0)
    leader.receive_reply(first.follower, _reply(followers, first, 1.001), 1.002)
    second = poll(leader, 1.002)
    assert second.follower != first.follower  # the first is fresh already: max-age moves on
    assert poll_message(second).seq == first.poll_seq + 1
    events = drain(leader)
    assert len(events) == 1 and isinstance(events[0], Delivered)
    assert (events[0].follower, events[0].payload) == (first.follower, FRAME)
    assert events[0].delivered_at == 1.002
    assert leader.stats(first.follower, 1.002).deliveries == 1


def test_a_checksum_failure_counts_no_freshness_and_asks_afresh() -> None:
    leader, followers = _two()
    first = poll(leader, 1.0)
    fid = first.follower
    assert fid == "a"  # its frame is from 0.5, b's from 0.25
    reply = decode_reply(_reply(followers, first, 1.001))
    assert reply.fragment is not None
    damaged = dataclasses.replace(reply.fragment, data=b"X" * len(reply.fragment.data))
    leader.receive_reply(fid, encode_reply(dataclasses.replace(reply, fragment=damaged)), 1.002)
    events = drain(leader)
    assert len(events) == 1 and isinstance(events[0], Rejected)
    assert "checksum" in events[0].reason
    assert leader.stats(fid, 1.002).errors == 1
    again = poll(leader, 1.002)
    assert again.follower == fid  # aged from 0 as before, not from its rejected frame
    assert poll_message(again).want == "fresh"


def test_the_work_of_two_replies_is_done_in_their_order() -> None:
    leader, followers = _two()
    first = poll(leader, 1.0)
    leader.receive_reply(first.follower, _reply(followers, first, 1.001), 1.002)
    second = poll(leader, 1.002)
    leader.receive_reply(second.follower, _reply(followers, second, 1.003), 1.004)
    events = drain(leader)
    assert [(type(e), e.follower) for e in events] == [(Delivered, first.follower),
                                                       (Delivered, second.follower)]


def test_a_timeout_counts_after_the_answer_before_it() -> None:
    leader, followers = _two()
    first = poll(leader, 1.0)
    leader.receive_reply(first.follower, _reply(followers, first, 1.001), 1.002)
    second = poll(leader, 1.002)
    leader.handle_timer(second.deadline)
    assert [(type(e), e.follower) for e in drain(leader)] == [
        (Delivered, first.follower), (TimedOut, second.follower),
        (Silent, second.follower)]  # it never answered: silent from its first miss


def test_a_follower_removed_after_its_answer_keeps_what_it_delivered() -> None:
    leader, followers = _two()
    first = poll(leader, 1.0)
    leader.receive_reply(first.follower, _reply(followers, first, 1.001), 1.002)
    leader.remove_follower(first.follower)
    assert [type(e) for e in drain(leader)] == [Delivered]  # it came while a member
    assert leader.followers == [fid for fid in followers if fid != first.follower]


def test_a_follower_restarting_before_its_events_are_taken_changes_nothing_of_them() -> None:
    """The update's time-stamp is put on the leader's clock with the clock estimate of
    the process that sent it, not of the one that replaced it."""
    leader = Leader()
    follower = Follower("a")
    leader.add_follower("a", 0.0)
    offset = 5.0  # the follower's clock is 5 s ahead
    for t in (1.0, 1.1, 1.2):
        follower.offer(FRAME, t - 0.1 + offset)
        request = poll(leader, t)
        events = on_reply(leader, "a", _reply({"a": follower}, request, t + 0.001 + offset),
                          t + 0.002)
        assert [type(e) for e in events] == [Delivered]
        assert events[0].generated_at == pytest.approx(t - 0.1, abs=1e-3)
    follower.offer(FRAME, 1.5 + offset)
    request = poll(leader, 2.0)
    leader.receive_reply("a", _reply({"a": follower}, request, 2.001 + offset), 2.002)
    leader.add_follower("a", 2.002)  # it restarted: its clock estimate starts over
    events = drain(leader)
    assert [type(e) for e in events] == [Delivered]
    assert events[0].generated_at == pytest.approx(1.5, abs=1e-3)
    restarted = Follower("a")  # the new process's clock is right
    restarted.offer(FRAME, 2.9)
    request = poll(leader, 3.0)  # a slower round trip than the one before the restart
    events = on_reply(leader, "a", _reply({"a": restarted}, request, 3.001), 3.004)
    assert [type(e) for e in events] == [Delivered]
    assert events[0].generated_at == pytest.approx(2.9, abs=1e-3)  # no sample of the old one
