"""The next poll before the reply is judged (``Leader.poll_on_answer``): only where the
reply's header decides the pick; a reply the judging then rejects or refuses loses
nothing, and a pick it undoes is counted."""

from __future__ import annotations

import dataclasses
import math

from hypothesis import given, settings
from hypothesis import strategies as st

from wiswarm_zenoh.core import (
    Delivered,
    Follower,
    FollowerConfig,
    Leader,
    LeaderConfig,
    Rejected,
    drain,
)
from wiswarm_zenoh.core.policies import IndexPolicy
from wiswarm_zenoh.core.scheduling import holds_on_answer, pick_after
from wiswarm_zenoh.core.wire import decode_reply, encode_reply

from .drive import poll
from .test_leader_fast_path import FRAME, _answer, _delivered, _picked_exchange, _swarm


def test_the_next_poll_goes_out_before_the_reply_is_judged_and_nothing_is_lost() -> None:
    leader, _, _, raw = _picked_exchange()
    following = leader.poll_on_answer("uav0", raw, 0.012)
    assert following is not None and following.follower != "uav0"
    assert following.steady is False  # (no poll answered yet: its timing is unmeasured)
    assert drain(leader) == []  # nothing judged yet
    leader.receive_reply("uav0", raw, 0.012)
    assert leader.in_flight == following.follower and leader.next_poll(0.012) is None
    assert _delivered(drain(leader)) == [("uav0", FRAME, 0.005)]
    assert (leader.early_polls, leader.fast_polls) == (1, 1)
    stats = leader.stats("uav0", 0.012)
    assert (stats.deliveries, stats.polls, stats.timeouts) == (1, 1, 0)


def test_no_early_poll_for_what_only_judging_can_tell() -> None:
    leader, followers, request, raw = _picked_exchange()
    nothing_new = encode_reply(dataclasses.replace(decode_reply(raw), fragment=None))
    for data in (b"\x00garbage", nothing_new):
        assert leader.poll_on_answer(request.follower, data, 0.012) is None
    assert leader.poll_on_answer("uav1", raw, 0.012) is None  # not the follower polled
    leader, followers = _swarm(3)
    followers["uav0"].offer(bytes(10_000), 0.0)  # three fragments of 4096 bytes
    request = poll(leader, 0.01)
    assert leader.next_poll(0.01) is None
    assert leader.poll_on_answer("uav0", _answer(followers, request), 0.012) is None
    assert leader.early_polls == 0


def test_no_early_poll_without_a_pick_or_with_several_polls_out() -> None:
    leader, followers = _swarm(3)
    followers["uav0"].offer(FRAME, 0.005)
    request = poll(leader, 0.01)  # no next_poll yet: no pick made
    assert leader.poll_on_answer("uav0", _answer(followers, request), 0.012) is None
    leader = Leader(LeaderConfig(in_flight=2))
    followers = {f"uav{i}": Follower(f"uav{i}", FollowerConfig(fragment_size=4096))
                 for i in range(3)}
    for fid, follower in followers.items():
        leader.add_follower(fid, 0.0)
        follower.offer(FRAME, 0.005)
    first, _ = poll(leader, 0.01), poll(leader, 0.01)
    assert leader.next_poll(0.01) is None
    assert leader.poll_on_answer(first.follower, _answer(followers, first), 0.012) is None


def test_a_reply_rejected_when_judged_leaves_its_follower_next() -> None:
    leader, followers, _, raw = _picked_exchange()
    reply = decode_reply(raw)
    assert reply.fragment is not None
    damaged = encode_reply(dataclasses.replace(reply, fragment=dataclasses.replace(
        reply.fragment, data=b"X" * len(reply.fragment.data))))
    following = leader.poll_on_answer("uav0", damaged, 0.012)
    assert following is not None  # the header promised a whole update
    leader.receive_reply("uav0", damaged, 0.012)
    events = drain(leader)
    assert len(events) == 1 and isinstance(events[0], Rejected)
    assert leader.stats("uav0", 0.012).deliveries == 0
    leader.receive_reply(following.follower, _answer(followers, following), 0.013)
    assert poll(leader, 0.013).follower == "uav0"  # still the oldest: polled on, afresh


def test_a_reply_refused_when_judged_leaves_its_poll_out_beside_the_early_one() -> None:
    leader, followers, request, raw = _picked_exchange()
    reply = decode_reply(raw)
    assert reply.fragment is not None
    forged = encode_reply(dataclasses.replace(reply, fragment=dataclasses.replace(
        reply.fragment, generated_at=reply.sent_at + 5.0)))  # made after it was sent
    following = leader.poll_on_answer("uav0", forged, 0.012)
    assert following is not None
    leader.receive_reply("uav0", forged, 0.012)
    assert [type(e) for e in drain(leader)] == [Rejected]
    assert leader.awaits("uav0", request.poll_seq)  # the genuine answer may still come
    assert leader.awaits(following.follower, following.poll_seq)
    assert leader.next_poll(0.012) is None  # no third
    leader.receive_reply("uav0", raw, 0.013)  # it does
    leader.receive_reply(following.follower, _answer(followers, following), 0.014)
    assert [e.follower for e in drain(leader) if isinstance(e, Delivered)] == [
        "uav0", following.follower]
    assert poll(leader, 0.014) is not None


@settings(max_examples=200, deadline=None)
@given(start=st.one_of(st.just(0.0), st.floats(1.6e9, 1.8e9)),
       weights=st.lists(st.floats(0.1, 10.0), min_size=3, max_size=3), ulps=st.integers(0, 4))
def test_a_reply_fresh_by_the_picks_bound_is_one_the_exact_check_passes(
        start: float, weights: list[float], ulps: int) -> None:
    """``Pick.holds_from`` (made with the pick, so that the reply's check computes no
    index) never says "holds" where the index says otherwise, at any clock's scale."""
    leader = Leader()
    for i, weight in enumerate(weights):
        leader.add_follower(f"uav{i}", start)
        leader.set_weight(f"uav{i}", weight)
    request = poll(leader, start + 0.01)
    assert isinstance(leader.policy, IndexPolicy)
    pick = pick_after(leader.table, leader.policy, leader.slot, request.poll_seq,
                      leader.table.index(request.follower), request.sent_at + leader.slot)
    assert pick is not None and math.isfinite(pick.holds_from)
    peer = leader.table.peers[request.follower]
    tau = pick.holds_from
    for _ in range(ulps):
        tau = math.nextafter(tau, math.inf)
    now = pick.at
    assert holds_on_answer(pick, leader.table, tau, peer.reliability.after(True), now)
