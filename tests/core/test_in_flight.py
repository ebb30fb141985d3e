"""Several polls out at once (``LeaderConfig.in_flight``), for a link that is not a
shared radio channel: each to another follower, answered in any order, each timed out
on its own deadline."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from wiswarm_zenoh.core import (
    Delivered,
    Follower,
    Leader,
    LeaderConfig,
    PollRequest,
    TimedOut,
    drain,
)
from wiswarm_zenoh.core.leader import END_GRACE

from .drive import on_reply

IDS = ("a", "b", "c", "d", "e")


def _leader(in_flight: int) -> tuple[Leader, dict[str, Follower]]:
    leader = Leader(LeaderConfig(in_flight=in_flight, timeout=0.1, adaptive_timeout=False))
    for follower in IDS:
        leader.add_follower(follower, 0.0)
    return leader, {f: Follower(f) for f in IDS}


def _fill(leader: Leader, now: float) -> list[PollRequest]:
    requests = []
    while (request := leader.next_poll(now)) is not None:
        requests.append(request)
    return requests


def test_up_to_k_polls_go_out_each_to_another_follower_and_come_back_in_any_order() -> None:
    leader, followers = _leader(3)
    for f in followers.values():
        f.offer(b"frame", 0.0)
    out = _fill(leader, 0.001)
    assert len(out) == 3 and len({r.follower for r in out}) == 3
    assert leader.get_timer() == min(r.deadline for r in out)
    raws = {r.follower: followers[r.follower].on_poll(r.payload, 0.002, 0.002) for r in out}
    last = out[-1]  # the last sent answers first
    events = on_reply(leader, last.follower, raws[last.follower], 0.003)
    assert [e.follower for e in events if isinstance(e, Delivered)] == [last.follower]
    again = leader.next_poll(0.003)  # a slot is free: the next poll goes out at once
    assert again is not None and again.follower not in {r.follower for r in out[:2]}
    assert leader.next_poll(0.003) is None  # three out again
    for request in out[:2]:  # then the others, in their order
        events = on_reply(leader, request.follower, raws[request.follower], 0.004)
        assert [e.follower for e in events if isinstance(e, Delivered)] == [request.follower]


def test_each_poll_out_times_out_on_its_own_deadline() -> None:
    leader, _ = _leader(2)
    first = leader.next_poll(0.0)
    second = leader.next_poll(0.05)
    assert first is not None and second is not None and leader.next_poll(0.05) is None
    leader.handle_timer(first.deadline)
    assert [e.follower for e in drain(leader) if isinstance(e, TimedOut)] == [first.follower]
    assert leader.get_timer() == second.deadline
    third = leader.next_poll(first.deadline)
    assert third is not None and third.follower != second.follower


def test_a_single_follower_is_never_polled_twice_at_once() -> None:
    leader = Leader(LeaderConfig(in_flight=4))
    leader.add_follower("only", 0.0)
    assert leader.next_poll(0.0) is not None
    assert leader.next_poll(0.0) is None


@settings(max_examples=60, deadline=None, derandomize=True)
@given(steps=st.lists(st.tuples(st.sampled_from(["poll", "answer", "timer", "end"]),
                                st.integers(0, 4)), max_size=80),
       in_flight=st.integers(1, 4))
def test_any_interleaving_keeps_k_distinct_polls_at_most_and_delivers_what_is_answered(
        steps: list[tuple[str, int]], in_flight: int) -> None:
    leader, followers = _leader(in_flight)
    out: dict[str, PollRequest] = {}
    now = 0.0
    for action, pick in steps:
        now += 0.01
        if action == "poll":
            request = leader.next_poll(now)
            if request is not None:
                assert request.follower not in out
                out[request.follower] = request
        elif action == "answer" and out:
            follower = sorted(out)[pick % len(out)]
            request = out.pop(follower)
            followers[follower].offer(b"x%d" % pick, now)
            raw = followers[follower].on_poll(request.payload, now, now)
            events = on_reply(leader, follower, raw, now)
            if now < request.deadline:
                assert any(isinstance(e, Delivered) and e.follower == follower
                           for e in events)
        elif action == "end" and out:  # its get is over, unanswered: the slot frees soon
            follower = sorted(out)[pick % len(out)]
            request = out.pop(follower)
            leader.receive_end(follower, request.poll_seq, now)
            leader.handle_timer(now + END_GRACE)
            assert TimedOut(follower, request.poll_seq) in drain(leader)
            out = {f: r for f, r in out.items() if now + END_GRACE < r.deadline}
        else:
            leader.handle_timer(now)
            drain(leader)
            out = {f: r for f, r in out.items() if now < r.deadline}
        assert len(out) <= in_flight
