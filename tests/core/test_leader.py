"""The leader state machine: polls, replies, timeouts, bad and stale input, control."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.core import (
    Answering,
    Delivered,
    Event,
    Follower,
    FollowerConfig,
    Leader,
    LeaderConfig,
    Rejected,
    Stale,
    drain,
)
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.core.fragments import checksum
from wiswarm_zenoh.core.wire import FragmentData, Reply, encode_reply

from .drive import answer, exchange, on_reply, on_timer, poll, poll_message


def _setup(*ids: str, config: LeaderConfig | None = None,
           follower_config: FollowerConfig | None = None) -> tuple[Leader, dict[str, Follower]]:
    leader = Leader(config or LeaderConfig())
    followers = {}
    for fid in ids:
        leader.add_follower(fid, 0.0)
        followers[fid] = Follower(fid, follower_config)
    return leader, followers


def _reply(fid: str, poll_seq: int, frag: FragmentData | None, at: float = 1.0) -> bytes:
    return encode_reply(Reply(fid, poll_seq, at, at, frag))


def _assert_delivered(events: list[Event], payload: bytes, generated_at: float, age: float,
                      update_seq: int) -> None:
    assert len(events) == 1 and isinstance(events[0], Delivered), events
    d = events[0]
    assert (d.follower, d.payload, d.update_seq) == ("a", payload, update_seq)
    assert d.generated_at == pytest.approx(generated_at)
    assert d.age == pytest.approx(age)


def _aoi(leader: Leader, fid: str, now: float) -> tuple[float, ...]:
    s = leader.stats(fid, now)
    return (s.aoi_s, s.mean_aoi_s, s.p95_aoi_s, s.peak_aoi_s, s.deliveries)


def test_poll_goes_to_the_first_joined_and_one_at_a_time() -> None:
    leader, _ = _setup("a", "b", config=LeaderConfig(timeout=0.25))
    assert Leader().next_poll(0.0) is None
    request = poll(leader, 0.0)
    assert (request.follower, request.poll_seq, request.deadline) == ("a", 1, 0.25)
    msg = poll_message(request)
    assert (msg.seq, msg.leader_time, msg.ack, msg.want) == (1, 0.0, None, "next")
    assert leader.next_poll(0.1) is None
    assert leader.in_flight == "a" and leader.get_timer() == 0.25
    assert leader.followers == ["a", "b"]


def test_reply_delivers_the_update_on_the_leader_clock() -> None:
    leader, followers = _setup("a")
    followers["a"].offer(b"frame", 0.5)
    _, _, events = exchange(leader, followers, 1.0)
    _assert_delivered(events, b"frame", generated_at=0.5, age=0.502, update_seq=1)
    s = leader.stats("a", 1.002)
    assert (s.polls, s.deliveries, s.timeouts, s.errors, s.stale) == (1, 1, 0, 0, 0)
    assert s.aoi_s == pytest.approx(0.502)
    assert s.p_hat == 1.0 and leader.get_timer() is None
    assert exchange(leader, followers, 1.1)[2] == []  # nothing new: answered, no event
    assert poll_message(poll(leader, 1.2)).ack == (1, 0)


def test_follower_clock_five_seconds_off() -> None:
    leader, followers = _setup("a")
    for k in range(1, 6):
        followers["a"].offer(bytes([k]), k + 5.0)  # stamped on the follower's clock
        _, _, events = exchange(leader, followers, k + 0.5, clock_offset=5.0)
        delivered = [e for e in events if isinstance(e, Delivered)]
        assert len(delivered) == 1
        assert delivered[0].generated_at == pytest.approx(float(k))
        assert delivered[0].age == pytest.approx(0.502)
    assert leader.stats("a", 6.0).clock_offset_s == pytest.approx(5.0)
    assert leader.stats("a", 5.502).aoi_s == pytest.approx(0.502)


def test_asymmetric_delays_use_the_fastest_exchange() -> None:
    leader, followers = _setup("a")
    f = followers["a"]
    for k, (up, down) in enumerate([(0.050, 0.001), (0.001, 0.001), (0.001, 0.080)]):
        t1 = 10.0 * k
        f.offer(bytes([k]), t1 + 5.0)
        request = poll(leader, t1)
        raw = f.on_poll(request.payload, t1 + up + 5.0, t1 + up + 5.0)
        on_reply(leader, "a", raw, t1 + up + down)
    assert leader.stats("a", 30.0).clock_offset_s == pytest.approx(5.0)


def test_duplicate_reply_is_stale() -> None:
    leader, followers = _setup("a")
    followers["a"].offer(b"x", 0.0)
    request = poll(leader, 1.0)
    raw = followers["a"].on_poll(request.payload, 1.001, 1.001)
    assert isinstance(on_reply(leader, "a", raw, 1.002)[0], Delivered)
    events = on_reply(leader, "a", raw, 1.003)
    assert len(events) == 1 and isinstance(events[0], Stale)
    s = leader.stats("a", 1.003)
    assert (s.deliveries, s.stale, s.errors) == (1, 1, 0)


def test_reply_from_a_follower_not_polled_is_stale() -> None:
    leader, _ = _setup("a", "b")
    request = poll(leader, 0.0)
    assert request.follower == "a"
    raw_b = _reply("b", request.poll_seq, None)  # right number, wrong key
    assert isinstance(on_reply(leader, "b", raw_b, 0.01)[0], Stale)
    assert leader.stats("b", 0.01).stale == 1
    assert leader.in_flight == "a"


def test_reply_claiming_another_sender_is_rejected() -> None:
    leader, _ = _setup("a", "b")
    request = poll(leader, 0.0)
    events = on_reply(leader, "a", _reply("b", request.poll_seq, None), 0.01)
    assert len(events) == 1 and isinstance(events[0], Rejected)
    assert leader.stats("a", 0.01).errors == 1
    assert leader.in_flight == "a"


def test_reply_from_a_stranger_is_stale_and_counted() -> None:
    leader, _ = _setup("a")
    events = on_reply(leader, "zz", b"\x00", 0.0)
    assert len(events) == 1 and isinstance(events[0], Stale)
    assert leader.unknown_replies == 1


@pytest.mark.parametrize("garbage", [b"", b"\xff\xfe", b"\x81\xa1v\x01", "not bytes", None])
def test_garbage_is_counted_as_an_error_without_changing_aoi(garbage: object) -> None:
    leader, followers = _setup("a")
    followers["a"].offer(b"x", 0.0)
    exchange(leader, followers, 0.5)
    before = _aoi(leader, "a", 3.0)
    request = poll(leader, 1.0)
    events = on_reply(leader, "a", garbage, 1.01)  # type: ignore[arg-type]
    assert len(events) == 1 and isinstance(events[0], Rejected)
    assert leader.stats("a", 3.0).errors == 1
    assert _aoi(leader, "a", 3.0) == before
    assert leader.in_flight == "a"  # still waiting for a valid reply
    assert on_reply(leader, "a", _reply("a", request.poll_seq, None), 1.02) == []


def test_checksum_mismatch_is_rejected_and_the_leader_asks_for_a_fresh_update() -> None:
    leader, _ = _setup("a")
    request = poll(leader, 1.0)
    frag = FragmentData(1, 0.5, 0, 1, 4, checksum(b"abcd") ^ 1, b"abcd")
    events = on_reply(leader, "a", _reply("a", request.poll_seq, frag), 1.01)
    assert len(events) == 1 and isinstance(events[0], Rejected)
    assert "checksum" in events[0].reason
    s = leader.stats("a", 1.01)
    assert (s.errors, s.deliveries, s.p_hat) == (1, 0, 1.0)  # answered, but unusable
    msg = poll_message(poll(leader, 1.1))
    assert (msg.ack, msg.want) == (None, "fresh")


def test_update_over_the_leader_limits_is_rejected() -> None:
    leader, _ = _setup("a", config=LeaderConfig(max_update_bytes=3, max_fragments=2))
    for frag in (FragmentData(1, 0.5, 0, 1, 4, checksum(b"abcd"), b"abcd"),
                 FragmentData(1, 0.5, 0, 3, 3, 0, b"a")):
        request = poll(leader, 1.0)
        events = on_reply(leader, "a", _reply("a", request.poll_seq, frag), 1.01)
        assert len(events) == 1 and isinstance(events[0], Rejected)
    assert leader.stats("a", 2.0).errors == 2


def test_fragmented_update_is_reassembled_across_polls_and_losses() -> None:
    cfg = FollowerConfig(fragment_size=FRAGMENT_HEADER_BYTES + 100)
    leader, followers = _setup("a", follower_config=cfg)
    payload = bytes(i % 251 for i in range(450))
    followers["a"].offer(payload, 0.5)
    delivered: list[Delivered] = []
    for k in range(8):
        t = 1.0 + k
        if k in (2, 3):  # both polls' replies lost
            request = poll(leader, t)
            followers["a"].on_poll(request.payload, t, t)
            on_timer(leader, request.deadline)
            continue
        delivered += [e for e in exchange(leader, followers, t)[2] if isinstance(e, Delivered)]
    assert [d.payload for d in delivered] == [payload]
    assert leader.stats("a", 9.0).timeouts == 2


def test_rejoin_after_restart_with_reset_sequence_numbers() -> None:
    cfg = FollowerConfig(fragment_size=FRAGMENT_HEADER_BYTES + 10)
    leader, followers = _setup("a", follower_config=cfg)
    for k in range(3):
        followers["a"].offer(bytes([k]), k + 0.25)
        exchange(leader, followers, k + 0.5)
    followers["a"].offer(bytes(30), 3.25)  # three fragments; one gets through
    exchange(leader, followers, 3.5)
    assert leader.stats("a", 4.0).deliveries == 3
    followers["a"] = Follower("a", cfg)  # restarted process: update seq back at 1
    leader.add_follower("a", 4.0)
    assert leader.followers == ["a"]
    followers["a"].offer(b"again", 4.1)
    request, reply, events = exchange(leader, followers, 4.5)
    assert (poll_message(request).ack, poll_message(request).want) == (None, "fresh")
    assert reply.fragment is not None and reply.fragment.update_seq == 1
    _assert_delivered(events, b"again", generated_at=4.1, age=0.402, update_seq=1)
    assert poll_message(poll(leader, 5.0)).want == "next"


def test_remove_while_in_flight() -> None:
    leader, followers = _setup("a", "b")
    followers["a"].offer(b"x", 0.0)
    request = poll(leader, 0.0)
    raw = followers["a"].on_poll(request.payload, 0.001, 0.001)
    leader.remove_follower("a")
    assert leader.followers == ["b"]
    assert leader.in_flight is None and leader.get_timer() is None
    assert on_timer(leader, 10.0) == []
    assert on_reply(leader, "a", raw, 0.002) == []  # it left: its answer is no bad input
    assert leader.unknown_replies == 0 and leader.stats("a", 0.002).deliveries == 0
    assert poll(leader, 0.01).follower == "b"
    assert leader.departed == ["a"]
    leader.forget_follower("a")
    events = on_reply(leader, "a", raw, 0.02)  # from a stranger now
    assert len(events) == 1 and isinstance(events[0], Stale)
    assert leader.unknown_replies == 1
    leader.remove_follower("a")  # already gone: nothing to do
    leader.remove_follower("b")
    assert leader.next_poll(1.0) is None


def test_a_follower_that_left_ages_honestly_until_forgotten_or_back() -> None:
    """A vanished follower (a site cut off upstream) is not reported fresh: its age keeps
    growing in its stats; back again, it is taken up where it was, not from age 0."""
    leader, followers = _setup("a", "b")
    followers["a"].offer(b"x", 0.0)
    _, _, events = exchange(leader, followers, 0.0)
    assert [type(e) for e in events] == [Delivered]
    leader.remove_follower("a")
    for now in (1.0, 5.0):
        gone = leader.stats("a", now)
        assert not gone.present and gone.aoi_s == pytest.approx(now, abs=0.01)
        assert poll(leader, now).follower == "b"  # a is polled no more
        leader.handle_timer(now + 1.0)
        drain(leader)
    leader.add_follower("a", 9.0)
    back = leader.stats("a", 9.0)
    assert back.present and back.aoi_s == pytest.approx(9.0, abs=0.01)  # not fresh
    assert back.deliveries == 1 and leader.departed == []
    leader.remove_follower("a")
    leader.forget_follower("a")
    with pytest.raises(ValueError, match="unknown follower"):
        leader.stats("a", 10.0)
    leader.add_follower("a", 11.0)  # forgotten: a newcomer
    assert leader.stats("a", 11.0).deliveries == 0


def test_a_follower_that_left_keeps_the_mean_and_p95_of_its_time_present() -> None:
    """Its age grows after it left, but a summary of how fresh it was (the leader's
    table at exit, its stats) counts only the time it was there."""
    leader, followers = _setup("a")
    t = 0.0
    for _ in range(100):
        t += 0.01
        followers["a"].offer(b"x", t - 0.002)
        exchange(leader, followers, t)
    present = leader.stats("a", t)
    leader.remove_follower("a", t)
    gone = leader.stats("a", t + 30.0)
    assert gone.aoi_s == pytest.approx(30.0, abs=0.1)  # not fresh
    assert gone.mean_aoi_s == pytest.approx(present.mean_aoi_s)
    assert gone.p95_aoi_s == pytest.approx(present.p95_aoi_s)
    assert gone.mean_aoi_s < 0.02


def test_remove_another_follower_keeps_the_poll_in_flight() -> None:
    leader, followers = _setup("a", "b", "c")
    followers["a"].offer(b"x", 0.0005)
    request = poll(leader, 0.001)
    leader.remove_follower("b")
    raw = followers["a"].on_poll(request.payload, 0.002, 0.002)
    assert [type(e) for e in on_reply(leader, "a", raw, 0.003)] == [Delivered]
    assert leader.stats("a", 0.003).p_hat == 1.0
    assert poll(leader, 0.01).follower == "c"


def test_heavier_follower_is_polled_first() -> None:
    leader, _ = _setup("a", "b", config=LeaderConfig(alpha=0.5))
    assert leader.observe_urgency("b", 3.0) == pytest.approx(2.0)
    assert leader.stats("b", 0.0).weight == pytest.approx(2.0)
    assert poll(leader, 1.0).follower == "b"  # equal ages: the heavier one
    with pytest.raises(ValueError, match="unknown follower"):
        leader.observe_urgency("zz", 1.0)
    with pytest.raises(ValueError, match="urgency"):
        leader.observe_urgency("a", -1.0)


def test_weight_floor_keeps_a_follower_without_urgency_in_the_schedule() -> None:
    leader, followers = _setup("a", "b", config=LeaderConfig(alpha=0.0, weight_floor=0.1))
    assert leader.observe_urgency("b", 0.0) == 0.0
    followers["a"].offer(b"1", 0.9)
    assert exchange(leader, followers, 1.0)[0].follower == "a"  # 1 * 1 > 0.1 * 1
    followers["a"].offer(b"2", 9.99)
    assert exchange(leader, followers, 10.0)[0].follower == "a"  # 9.1^2 > 0.1 * 10^2
    # a: 0.51^2 = 0.26 < b: 0.1 * 10.5^2 = 11 (with weight 0, b would never be chosen)
    assert poll(leader, 10.5).follower == "b"


def test_first_update_generated_before_the_follower_was_added_is_delivered() -> None:
    """A follower is discovered while its freshest update already waits: the application
    must still get that update (nothing was delivered before, so it is not stale)."""
    leader = Leader()
    follower = Follower("a")
    follower.offer(b"first frame", 9.95)
    leader.add_follower("a", 10.0)
    events = answer(leader, {"a": follower}, poll(leader, 10.0), 10.0)
    assert [type(e).__name__ for e in events] == ["Delivered"]


def test_follower_with_nothing_to_send_does_not_starve_the_others() -> None:
    """b is up but has produced nothing yet (camera warming up): its age, counted from
    when it joined, only grows, but polling it again cannot lower it; a must still be
    polled and its AoI stay near the poll period. (The paper's index: a's camera's
    phase would hold some polls, which ``exchange`` does not wait for.)"""
    leader, followers = _setup("a", "b", config=LeaderConfig(pace_sources=False))
    t, polled = 0.0, {"a": 0, "b": 0}
    for _ in range(50):
        t += 0.01
        followers["a"].offer(b"frame", t - 0.005)
        polled[exchange(leader, followers, t)[0].follower] += 1
    assert polled["a"] >= 10
    assert leader.stats("a", t).aoi_s < 0.1


def test_update_whose_reply_was_lost_after_a_rejoin_is_still_delivered() -> None:
    leader, followers = _setup("a")
    followers["a"] = Follower("a")  # restarted
    leader.add_follower("a", 1.0)
    followers["a"].offer(b"only frame", 1.5)
    request = poll(leader, 2.0)
    followers["a"].on_poll(request.payload, 2.001, 2.001)  # the reply is lost
    on_timer(leader, request.deadline)  # its first poll since it restarted went unanswered
    events = answer(leader, followers, poll(leader, 3.0), 3.0)
    assert [type(e) for e in events] == [Answering, Delivered]
