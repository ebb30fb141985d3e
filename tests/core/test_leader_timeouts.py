"""What an unanswered poll costs and teaches: timeouts, late replies, silent followers."""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import pytest

from wiswarm_zenoh.core import (
    Answering,
    Delivered,
    Follower,
    Leader,
    LeaderConfig,
    Silent,
    Stale,
    TimedOut,
)

from .drive import answer, exchange, on_reply, on_timer, poll
from .test_leader import _aoi, _setup


def test_timeout_lowers_p_hat_and_only_the_timer_ends_an_unanswered_poll() -> None:
    leader, followers = _setup("a", config=LeaderConfig(window=20, prior_p=1.0, timeout=0.3,
                                                        adaptive_timeout=False))
    exchange(leader, followers, 0.0)  # it answered once: a timeout now is no verdict
    request = poll(leader, 1.0)
    assert on_timer(leader, 1.29) == []
    assert on_timer(leader, 1.3) == [TimedOut("a", request.poll_seq)]
    assert on_timer(leader, 1.4) == []
    assert leader.stats("a", 1.3).p_hat == pytest.approx(0.95)
    request = poll(leader, 2.0)
    assert leader.get_timer() == pytest.approx(2.3)
    assert on_timer(leader, 2.3) == [TimedOut("a", request.poll_seq)]
    s = leader.stats("a", 3.0)
    assert (s.timeouts, s.polls) == (2, 3)
    assert s.p_hat == pytest.approx(0.9)
    exchange(leader, followers, 3.0)
    assert leader.in_flight is None
    assert on_timer(leader, 3.5) == []  # a valid reply came: answered
    assert leader.stats("a", 3.1).p_hat == pytest.approx(0.9)
    assert leader.stats("a", 3.1).timeouts == 2


def test_a_member_that_never_answered_is_silent_from_its_first_miss() -> None:
    """A token with nothing behind it, a hung or garbage-speaking queryable: one poll,
    then probes alone with back-off, never the W polls at full price of one that
    answered before; its first answer brings it in with its prior back."""
    leader, followers = _setup("a", "ghost")
    t = 0.0
    while (request := poll(leader, t)).follower != "ghost":  # a answers in 1 ms
        followers["a"].offer(b"frame", t)
        on_reply(leader, "a", followers["a"].on_poll(request.payload, t, t), t + 0.001)
        t += 0.01
    assert leader.stats("a", t).polls >= 1
    # judged by the swarm's polls, not the 0.3 s ceiling: twice the longest, the floor
    assert request.deadline - request.sent_at == pytest.approx(leader.config.timeout_floor)
    events = on_timer(leader, request.deadline)
    assert events == [TimedOut("ghost", request.poll_seq), Silent("ghost", 1, False)]
    assert leader.stats("ghost", request.deadline).p_hat == 0.0
    silent_at = t = request.deadline
    followers["ghost"].offer(b"late frame", t)
    while (request := poll(leader, t)).follower != "ghost":  # probed after probe_interval
        followers["a"].offer(b"frame", t)
        on_reply(leader, "a", followers["a"].on_poll(request.payload, t, t), t + 0.001)
        t += 0.05
    assert request.sent_at >= silent_at + leader.config.probe_interval
    events = answer(leader, followers, request, request.sent_at + 0.001)
    assert [type(e) for e in events] == [Answering, Delivered]
    assert leader.stats("ghost", t).p_hat == pytest.approx(0.95)  # 1 miss, 1 answer, prior


def test_reply_after_the_timeout_is_stale_and_lengthens_the_next_timeout() -> None:
    leader, followers = _setup("a")
    followers["a"].offer(b"x", 0.0)
    first = poll(leader, 0.0)  # a quick answer: the timeout shrinks to the floor
    on_reply(leader, "a", followers["a"].on_poll(first.payload, 0.001, 0.001), 0.002)
    request = poll(leader, 1.0)
    assert request.deadline == pytest.approx(1.0 + leader.config.timeout_floor)
    raw = followers["a"].on_poll(request.payload, 1.1, 1.1)
    on_timer(leader, request.deadline)
    before = _aoi(leader, "a", 2.0)
    assert on_reply(leader, "a", raw, 1.5) == []  # late, not bad: nothing to report
    assert _aoi(leader, "a", 2.0) == before
    assert leader.stats("a", 2.0).stale == 1
    # twice the late one, up to the ceiling
    assert poll(leader, 2.0).deadline == pytest.approx(2.0 + min(2 * 0.5, leader.config.timeout))
    again = followers["a"].on_poll(request.payload, 2.1, 2.1)  # the same late reply again
    assert on_reply(leader, "a", again, 2.2) == [Stale("a", "reply to poll 2, not one out")]



def test_a_late_reply_to_an_earlier_timed_out_poll_still_lengthens_the_timeout() -> None:
    """On a link slower than measured the leader polls again at each timeout, and the
    replies queue behind each other: the first late reply answers the first of those
    polls, not the last."""
    leader, followers = _setup("a")
    followers["a"].offer(b"x", 0.0)
    first = poll(leader, 0.0)
    on_reply(leader, "a", followers["a"].on_poll(first.payload, 0.001, 0.001), 0.002)
    sent = []
    for k in range(3):
        request = poll(leader, 1.0 + k)
        sent.append(request)
        on_timer(leader, request.deadline)
    raw = followers["a"].on_poll(sent[0].payload, 1.2, 1.2)
    assert on_reply(leader, "a", raw, 3.3) == []  # late, not bad: nothing to report
    assert poll(leader, 4.0).deadline == pytest.approx(4.0 + leader.config.timeout)

def _run_with_a_dead_follower(
    leader: Leader, followers: Mapping[str, Follower], until: float, start: float = 0.0
) -> tuple[list[float], float]:
    """Poll from ``start`` until ``until``; "dead" never answers. Returns the times it
    was polled, and the time reached."""
    t, dead_polls = start, []
    while t < until:
        request = poll(leader, t)
        if request.follower == "dead":
            dead_polls.append(t)
            t = request.deadline
            on_timer(leader, t)
        else:
            followers["a"].offer(b"x", t)
            answer(leader, followers, request, t)
            t += 0.002
    return dead_polls, t


def _answered_once(config: LeaderConfig) -> tuple[Leader, dict[str, Follower], float]:
    """A swarm of "a" and "dead", where "dead" answered one poll (then died)."""
    leader, followers = _setup("a", "dead", config=config)
    t = 0.0
    while (request := poll(leader, t)).follower != "dead":
        followers["a"].offer(b"x", t)
        answer(leader, followers, request, t)
        t += 0.002
    followers["dead"].offer(b"last words", t)
    answer(leader, followers, request, t)
    return leader, dict(followers), t + 0.002


def test_silent_follower_is_probed_with_back_off_and_cannot_starve_the_others() -> None:
    config = LeaderConfig(window=5, timeout=0.1, probe_interval=0.5, probe_max=4.0,
                          adaptive_timeout=False)
    leader, followers, t = _answered_once(config)
    dead_polls, t = _run_with_a_dead_follower(leader, followers, 30.0, start=t)
    assert leader.stats("dead", t).p_hat == 0.0
    # 5 polls to fall silent, then probes 0.5, 1, 2, 4, 4, 4... s apart
    probes = dead_polls[5:]
    gaps = [round(b - a - 0.1, 6) for a, b in itertools.pairwise(probes)]
    assert gaps[:4] == pytest.approx([1.0, 2.0, 4.0, 4.0], abs=0.01)
    assert 8 <= len(dead_polls) <= 14
    # the healthy follower is served all the time in between: its age stays small
    assert leader.stats("a", t).mean_aoi_s < 0.05


def test_a_probe_answered_brings_the_follower_back_into_the_schedule() -> None:
    config = LeaderConfig(window=2, timeout=0.1, probe_interval=0.5, adaptive_timeout=False)
    leader, followers, t = _answered_once(config)
    dead_polls, t = _run_with_a_dead_follower(leader, followers, 0.5, start=t)
    assert len(dead_polls) == 2 and leader.stats("dead", t).p_hat == 0.0
    probe_due = dead_polls[-1] + 0.1 + 0.5
    quiet, t = _run_with_a_dead_follower(leader, followers, probe_due - 0.01, start=t)
    assert quiet == []
    while (request := poll(leader, t)).follower != "dead":
        followers["a"].offer(b"x", t)
        answer(leader, followers, request, t)
        t += 0.002
    assert probe_due <= t < probe_due + 0.01
    followers["dead"].offer(b"back", t)
    answer(leader, followers, request, t)
    assert leader.stats("dead", t + 0.01).p_hat == 0.5
    assert leader.stats("dead", t + 0.01).deliveries == 2  # its last words, and now


def test_a_dead_follower_that_rejoins_is_polled_at_once_with_the_p_it_had() -> None:
    """Its probes had backed off to ``probe_max`` while its process was dead; its token's
    return (a new process) says it is up: it is polled on its index at once, and the
    polls it missed while gone do not count against its link."""
    config = LeaderConfig(window=5, timeout=0.1, probe_interval=0.5, probe_max=8.0,
                          adaptive_timeout=False)
    leader, followers, t = _answered_once(config)
    dead_polls, t = _run_with_a_dead_follower(leader, followers, 20.0, start=t)
    assert leader.stats("dead", t).p_hat == 0.0
    assert dead_polls[-1] - dead_polls[-2] == pytest.approx(8.0 + 0.1)  # backed off fully
    leader.remove_follower("dead", t)  # its token went
    followers["dead"] = Follower("dead")  # started again
    leader.add_follower("dead", t + 0.2)
    assert leader.stats("dead", t + 0.2).p_hat == 1.0  # one answer, no miss of its link
    t = rejoined = t + 0.2
    while (request := poll(leader, t)).follower != "dead":
        followers["a"].offer(b"x", t)
        answer(leader, followers, request, t)
        t += 0.002
    assert t <= rejoined + 0.002  # at once (its age is the larger), not up to 8 s on
    followers["dead"].offer(b"back", t)
    assert any(isinstance(e, Delivered) for e in answer(leader, followers, request, t))


def _nobody_there(leader: Leader, start: float, until: float) -> float:
    """Every poll from ``start`` to ``until`` ends at once, as a get with no queryable
    does while the followers' process is gone; the time reached."""
    t = start
    while t < until:
        request = poll(leader, t)
        leader.receive_end(request.follower, request.poll_seq, t + 0.001)
        t = request.deadline
        on_timer(leader, t)
    return t


def test_followers_gone_together_do_not_back_off_on_probes_sent_before_they_were_due() -> None:
    """With every follower silent, each is polled on before its probe is due, and with
    nobody there each poll ends in milliseconds. The back-off grew on each of them, to
    ``probe_max`` within 40 ms, so of two followers restarted together, the one that
    answered second waited 8 s for its next probe (a testbed run's killed followers
    process). It grows once per back-off, as when the others answer."""
    config = LeaderConfig(window=2, timeout=0.1, probe_interval=0.5, probe_max=8.0,
                          adaptive_timeout=False)
    leader, followers = _setup("a", "b", config=config)
    t = 0.0
    for _ in range(2):
        exchange(leader, followers, t)
        t += 0.002
    gone = t
    t = _nobody_there(leader, t, 1.0)
    assert leader.stats("a", t).p_hat == leader.stats("b", t).p_hat == 0.0
    assert leader.stats("a", t).polls + leader.stats("b", t).polls > 100  # polled on
    back = t  # both processes are up again; "a" is probed first and answers
    b_polls = []
    while t < back + 2.0:
        request = poll(leader, t)
        if request.follower == "b":
            b_polls.append(t)
        followers[request.follower].offer(b"x", t)
        answer(leader, followers, request, t)
        t += 0.002
    # its probes backed off with the time it was gone (0.5 s, then 1 s), not per poll
    assert b_polls and b_polls[0] - back <= back - gone


def test_a_silent_member_whose_token_came_back_is_probed_at_once() -> None:
    """Its token went and came back within the shell's grace (a router failover, or a
    process restarted that fast): it is up, so a back-off grown while it was away does
    not keep it unpolled; its estimates stay as they were."""
    config = LeaderConfig(window=5, timeout=0.1, probe_interval=0.5, probe_max=8.0,
                          adaptive_timeout=False)
    leader, followers, t = _answered_once(config)
    dead_polls, t = _run_with_a_dead_follower(leader, followers, 20.0, start=t)
    assert dead_polls[-1] - dead_polls[-2] == pytest.approx(8.0 + 0.1)  # backed off fully
    assert poll(leader, t).follower == "a"  # its probe is seconds away
    on_timer(leader, t + 1.0)
    t += 1.0
    leader.follower_reachable("dead")
    assert poll(leader, t).follower == "dead"
    assert leader.stats("dead", t).p_hat == 0.0  # still silent until it answers
