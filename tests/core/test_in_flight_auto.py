"""``in_flight="auto"``: the leader finds how many polls to keep out from its own
throughput: 1 where every poll crosses one bottleneck, about (round trip + service) /
service where the polls wait out a round trip that the link could fill."""

from __future__ import annotations

import heapq
import itertools

import pytest

from wiswarm_zenoh.core import AoITracker, Delivered, Follower, Leader, LeaderConfig, drain
from wiswarm_zenoh.core.in_flight import InFlightTuner

WARMUP = 15.0  # seconds before the AoI is measured: the climb from K = 1 is over


def _run(n: int, service: float, one_way: float, seconds: float = 60.0,
         in_flight: int | str = "auto") -> tuple[Leader, list[int], float]:
    """N followers behind one FIFO bottleneck that takes ``service`` s per reply, polls
    and replies ``one_way`` s each way; returns the leader, its limit over time and the
    mean AoI of the followers after ``WARMUP``."""
    leader = Leader(LeaderConfig(in_flight=in_flight))  # type: ignore[arg-type]
    followers = {f"f{i}": Follower(f"f{i}") for i in range(n)}
    for f in followers:
        leader.add_follower(f, 0.0)
    arrivals: list[tuple[float, int, str, bytes]] = []  # replies on their way
    link_free, now, seq, limits = 0.0, 0.0, 0, []
    ages = {f: AoITracker(WARMUP, initial_age=WARMUP) for f in followers}
    while now < seconds:
        while (request := leader.next_poll(now)) is not None:
            follower = followers[request.follower]
            at = now + one_way
            follower.offer(b"frame", at)
            raw = follower.on_poll(request.payload, at, at)
            link_free = max(link_free, at) + service  # queued behind the replies before
            seq += 1
            heapq.heappush(arrivals, (link_free + one_way, seq, request.follower, raw))
        now, _, who, raw = heapq.heappop(arrivals)
        leader.receive_reply(who, raw, now)
        for event in drain(leader):
            if isinstance(event, Delivered) and now >= WARMUP:
                ages[event.follower].deliver(event.generated_at, now)
        limits.append(leader.polls_allowed)
    return leader, limits, sum(a.mean(now) for a in ages.values()) / n


def test_over_one_bottleneck_it_stays_at_one() -> None:
    leader, limits, auto = _run(n=8, service=0.02, one_way=0.0002)
    assert leader.tuner is not None and leader.tuner.limit == 1
    assert sum(k > 1 for k in limits) / len(limits) < 0.1  # trials: rare, and short
    assert auto <= 1.05 * _run(n=8, service=0.02, one_way=0.0002, in_flight=1)[2]


def test_across_a_wan_it_climbs_to_what_fills_the_link() -> None:
    leader, _, auto = _run(n=12, service=0.005, one_way=0.025)  # best: (50 + 5) / 5 = 11
    assert leader.tuner is not None and 9 <= leader.tuner.limit <= 12
    best = min(_run(n=12, service=0.005, one_way=0.025, in_flight=k)[2] for k in range(9, 13))
    assert auto <= 1.1 * best


def test_a_trial_that_loses_waits_twice_as_long_before_the_next() -> None:
    tuner = InFlightTuner()
    now, trials = 0.0, []
    for _ in range(4000):  # a shared channel: 10 answers a second whatever K
        now += 0.1 if tuner.current == 1 else 0.1 * tuner.current
        tuner.completed(True, now, 8)
        trials.append(tuner.current)
    starts = [i for i in range(1, len(trials)) if trials[i] > 1 and trials[i - 1] == 1]
    gaps = [b - a for a, b in itertools.pairwise(starts)]
    assert gaps == sorted(gaps) and gaps[-1] == pytest.approx(gaps[-2], rel=0.1)
    assert tuner.limit == 1
