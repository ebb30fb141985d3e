"""The fast path (``prepare``, then ``reply_and_poll``): the next poll goes out before
the reply is taken, to the follower the usual path would have picked, and the reply
taken that way is delivered at ``settle`` like any other."""

from __future__ import annotations

import dataclasses
import random

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
)
from wiswarm_zenoh.core.peers import FEW
from wiswarm_zenoh.core.wire import FragmentData, Reply, decode_reply, encode_reply

from .drive import poll

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


def _usual(leader: Leader, request: PollRequest, raw: bytes, now: float) -> PollRequest:
    leader.accept_reply(request.follower, raw, now)
    return poll(leader, now)


def _delivered(events: list[Event]) -> list[tuple[str, bytes, float]]:
    return [(e.follower, e.payload, e.generated_at) for e in events if isinstance(e, Delivered)]


def _compare_paths(n: int, weights: list[float], offers: list[tuple[int, float]]) -> int:
    """Two swarms fed the same frames: one leader takes every reply the usual way, the
    other on the fast path where it can. Both must poll the same followers in the same
    order and deliver the same updates. Returns how many polls took the fast path."""
    usual, usual_followers = _swarm(n)
    fast, fast_followers = _swarm(n)
    for leader in (usual, fast):
        for i, weight in enumerate(weights[:n]):
            leader.observe_urgency(f"uav{i}", weight)
    usual_request, fast_request = poll(usual, 0.0), poll(fast, 0.0)
    usual_events: list[Event] = []
    fast_events: list[Event] = []
    for step, (who, made_before) in enumerate(offers):
        for followers in (usual_followers, fast_followers):
            followers[f"uav{who % n}"].offer(FRAME + bytes([step % 256]),
                                             usual_request.sent_at - made_before)
        fast.prepare()
        arrives = fast_request.sent_at + fast.slot  # when prepare expected it: same ages
        next_fast = fast.reply_and_poll(fast_request.follower,
                                        _answer(fast_followers, fast_request), arrives)
        if next_fast is None:
            next_fast = _usual(fast, fast_request, _answer(fast_followers, fast_request), arrives)
        fast_events += fast.settle()
        usual_request = _usual(usual, usual_request, _answer(usual_followers, usual_request),
                               arrives)
        usual_events += usual.settle()
        fast_request = next_fast
        assert fast_request.follower == usual_request.follower, step
    assert _delivered(fast_events) == _delivered(usual_events)
    assert usual.fast_polls == 0
    return fast.fast_polls


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(2, 6),
    weights=st.lists(st.floats(0.1, 10.0), min_size=6, max_size=6),
    offers=st.lists(st.tuples(st.integers(0, 5), st.floats(0.0, 0.002)), max_size=60),
)
def test_the_fast_path_picks_what_the_usual_path_picks(
        n: int, weights: list[float], offers: list[tuple[int, float]]) -> None:
    assert _compare_paths(n, weights, offers) >= len(offers) // 2  # mostly fast


def test_the_fast_path_picks_what_the_usual_path_picks_among_many() -> None:
    n = FEW + 6  # numpy's side of prepare
    rng = random.Random(3)
    weights = [rng.uniform(0.1, 10.0) for _ in range(n)]
    offers = [(rng.randrange(n), rng.uniform(0.0, 0.002)) for _ in range(300)]
    assert _compare_paths(n, weights, offers) >= 150


def _prepared_exchange(n: int = 3) -> tuple[Leader, dict[str, Follower], PollRequest, bytes]:
    leader, followers = _swarm(n)
    for follower in followers.values():
        follower.offer(FRAME, 0.005)
    request = poll(leader, 0.01)
    leader.prepare()
    return leader, followers, request, _answer(followers, request)


def test_a_reply_taken_fast_is_delivered_at_settle_and_counted() -> None:
    leader, _, request, raw = _prepared_exchange()
    assert request.follower == "uav0"  # all equally old: the first joined
    following = leader.reply_and_poll("uav0", raw, 0.012)
    assert following is not None and following.follower != "uav0"
    assert leader.in_flight == following.follower
    assert leader.stats("uav0", 0.012).deliveries == 0  # taken, not settled yet
    events = leader.settle()
    assert _delivered(events) == [("uav0", FRAME, 0.005)]
    stats = leader.stats("uav0", 0.012)
    assert (stats.deliveries, stats.polls, stats.timeouts) == (1, 1, 0)
    assert leader.settle() == []


def test_a_checksum_failure_found_at_settle_is_rejected() -> None:
    leader, _, request, raw = _prepared_exchange()
    reply = decode_reply(raw)
    assert reply.fragment is not None
    damaged = dataclasses.replace(reply.fragment, data=b"X" * len(reply.fragment.data))
    bad = encode_reply(dataclasses.replace(reply, fragment=damaged))
    assert leader.reply_and_poll(request.follower, bad, 0.012) is not None
    events = leader.settle()
    assert len(events) == 1 and isinstance(events[0], Rejected)
    assert leader.stats(request.follower, 0.012).deliveries == 0


def _declines(leader: Leader, request: PollRequest, raw: bytes, follower: str = "",
              now: float = 0.012) -> None:
    """reply_and_poll says None and leaves the poll in flight for the usual path."""
    assert leader.reply_and_poll(follower or request.follower, raw, now) is None
    assert leader.in_flight == request.follower
    leader.accept_reply(request.follower, raw, now)
    assert leader.in_flight is None


def test_declines_when_nothing_was_prepared_or_the_swarm_changed() -> None:
    leader, _, request, raw = _prepared_exchange()
    leader.observe_urgency("uav1", 5.0)  # a new weight: the pick may be another now
    _declines(leader, request, raw)
    leader, _, request, raw = _prepared_exchange()
    leader.add_follower("uav9", 0.005)
    _declines(leader, request, raw)
    leader, _, request, raw = _prepared_exchange(n=1)  # nobody else to pick
    _declines(leader, request, raw)


def test_declines_for_a_late_reply() -> None:
    leader, _, request, raw = _prepared_exchange()
    late = request.sent_at + 2 * leader.slot + 0.001  # the ages prepared are off by more
    assert leader.reply_and_poll(request.follower, raw, late) is None
    assert leader.in_flight == request.follower


def test_declines_for_a_policy_without_an_index() -> None:
    leader, followers = _swarm(3, LeaderConfig(policy="round-robin"))
    request = poll(leader, 0.01)
    leader.prepare()
    _declines(leader, request, _answer(followers, request))


def test_declines_for_bad_stale_or_foreign_replies() -> None:
    leader, _, request, raw = _prepared_exchange()
    for data, sender in ((b"\x00garbage", ""), (raw, "uav1"),
                         (encode_reply(dataclasses.replace(decode_reply(raw), poll_seq=7)), "")):
        assert leader.reply_and_poll(sender or request.follower, data, 0.012) is None
        assert leader.in_flight == request.follower
        leader.prepare()
    assert leader.reply_and_poll(request.follower, raw, 0.012) is not None  # all as before


def test_declines_for_a_fragment_of_a_larger_update() -> None:
    leader, followers = _swarm(3)
    followers["uav0"].offer(bytes(10_000), 0.0)  # three fragments of 4096 bytes
    request = poll(leader, 0.01)
    leader.prepare()
    _declines(leader, request, _answer(followers, request))


def test_a_follower_whose_answer_leaves_it_oldest_keeps_its_turn() -> None:
    leader, _ = _swarm(2)
    leader.observe_urgency("uav0", 10.0)  # the heavier: polled first
    request = poll(leader, 10.0)
    assert request.follower == "uav0"
    leader.prepare()
    # Its update is older than anything the leader has seen (a backlog): still first.
    old = FragmentData(1, -100.0, 0, 1, len(FRAME), 0, FRAME)
    raw = encode_reply(Reply(request.follower, request.poll_seq, 10.001, 10.001, old))
    _declines(leader, request, raw, now=10.002)
