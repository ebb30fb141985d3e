"""A source slower than the polls: the leader learns its pace from the updates it takes
and polls it when a poll can find something new (``core.sources``)."""

from __future__ import annotations

import math

import pytest

from wiswarm_zenoh.core import Follower, Leader, LeaderConfig, drain
from wiswarm_zenoh.core.sources import MAX_BACKOFF, SourcePace, reducible_age


def test_the_interval_is_the_generation_gap_over_the_sequence_gap() -> None:
    pace = SourcePace()
    pace.taken(1, 10.0, 110.0)
    assert pace.interval == 0.0 and not pace.paced  # one update: nothing known
    pace.taken(4, 10.03, 110.03)  # polled every 30 ms, a camera at 100 Hz: 3 made
    assert pace.interval == pytest.approx(0.01)
    assert not pace.paced  # never found empty: taken as always fresh (the paper's)
    pace.empty(110.035)
    assert pace.paced and pace.due == pytest.approx(110.04)  # 10 ms after the last one
    pace.taken(2, 0.5, 111.0)  # the follower restarted: its sequence went back
    assert pace.interval == 0.0


def test_empty_answers_back_off_by_a_quarter_interval_doubling_up_to_a_limit() -> None:
    pace = SourcePace()
    pace.taken(1, 0.0, 0.0)
    pace.taken(2, 0.2, 0.2)  # 5 Hz
    waits = []
    for k in range(12):
        now = 0.45 + k  # after it was due (0.4), and nothing came
        pace.empty(now)
        waits.append(round(pace.due - now, 6))
    assert waits[:3] == [0.05, 0.1, 0.2] and waits[-1] == MAX_BACKOFF
    pace.taken(3, 0.4, 12.0)  # answered with an update: due one interval after it
    assert pace.empties == 0 and pace.due == pytest.approx(12.2)


def test_the_reducible_age_is_the_papers_age_when_fresh_and_zero_before_due() -> None:
    assert reducible_age(0.3, now=5.0, due=-math.inf, interval=0.0) == 0.3
    assert reducible_age(0.15, now=5.0, due=5.05, interval=0.2) == 0.0  # nothing new yet
    # due, 0.25 s old: the freshest waiting was made 0.05 s ago: sqrt(A^2 - z^2)
    assert reducible_age(0.25, now=5.0, due=4.95, interval=0.2) == pytest.approx(
        math.sqrt(0.25**2 - 0.05**2))


def _run(pace_sources: bool, seconds: float = 20.0) -> tuple[Leader, dict[str, int]]:
    """Two cameras at 100 Hz and two at 5 Hz, polls of 2 ms (a shared channel about
    half busy): how many polls found nothing new, per follower."""
    leader = Leader(LeaderConfig(pace_sources=pace_sources))
    intervals = {"fast0": 0.01, "fast1": 0.01, "slow0": 0.2, "slow1": 0.2}
    followers = {f: Follower(f) for f in intervals}
    for f in followers:
        leader.add_follower(f, 0.0)
    made = dict.fromkeys(intervals, 0.0)
    empty = dict.fromkeys(intervals, 0)
    now = 0.0
    while now < seconds:
        request = leader.next_poll(now)
        if request is None:  # no source is due: the leader says when one is
            wake = leader.get_timer()
            assert wake is not None and wake > now
            now = wake
            continue
        at = now + 0.001
        for f, interval in intervals.items():  # every frame made until the poll lands
            while made[f] + interval <= at:
                made[f] += interval
                followers[f].offer(b"frame", made[f])
        raw = followers[request.follower].on_poll(request.payload, at, at)
        leader.receive_reply(request.follower, raw, at + 0.001)
        events = drain(leader)
        if not events:
            empty[request.follower] += 1
        now = at + 0.001
    return leader, empty


def test_slow_sources_are_polled_when_due_and_the_fast_ones_gain_the_time() -> None:
    paced, empty_paced = _run(pace_sources=True)
    papers, empty_papers = _run(pace_sources=False)
    share = sum(empty_paced.values()) / paced.polls
    assert share <= 0.10  # the target; the paper's index: most polls are empty
    assert sum(empty_papers.values()) / papers.polls > 0.5
    for f in ("slow0", "slow1"):  # each slow frame still taken about when made
        assert paced.stats(f, 20.0).mean_aoi_s < 0.2
    fast = [paced.stats(f, 20.0).mean_aoi_s for f in ("fast0", "fast1")]
    fast_papers = [papers.stats(f, 20.0).mean_aoi_s for f in ("fast0", "fast1")]
    assert sum(fast) <= sum(fast_papers) * 1.01
