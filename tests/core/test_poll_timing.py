"""Each follower's timeout from its own polls, and what a lost poll costs the index."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.core.poll_timing import SAMPLES, PollTiming, SwarmPollTimes


def test_the_first_poll_waits_the_ceiling_then_twice_the_longest_answer_over_a_floor() -> None:
    timing = PollTiming(ceiling=0.3, floor=0.01)
    assert timing.timeout == 0.3  # nothing known yet, of it or of the swarm
    timing.answered(0.0006)
    assert timing.timeout == 0.01  # a fast link: the floor
    timing.answered(0.021)  # a 50 kB frame at 20 Mbit/s
    assert timing.timeout == pytest.approx(0.042)
    for _ in range(SAMPLES):
        timing.answered(0.0006)
    assert timing.timeout == 0.01  # the slow one aged out of the window
    timing.answered(1.0)
    assert timing.timeout == 0.3  # never over the ceiling


def test_only_probes_of_a_silent_follower_double_the_wait_and_an_answer_resets_it() -> None:
    timing = PollTiming(ceiling=0.3, floor=0.01)
    timing.answered(0.001)
    for _ in range(5):
        timing.timed_out(silent=False)
    assert timing.timeout == 0.01  # a follower that just died costs the floor per poll
    waits = []
    for _ in range(6):
        timing.timed_out(silent=True)
        waits.append(timing.timeout)
    assert waits == pytest.approx([0.02, 0.04, 0.08, 0.16, 0.3, 0.3])
    timing.answered(0.05)  # back, on a slower link
    assert timing.timeout == pytest.approx(0.1)


def test_a_follower_not_measured_yet_is_judged_by_the_swarms_polls() -> None:
    swarm = SwarmPollTimes()
    newcomer = PollTiming(ceiling=0.3, floor=0.01, swarm=swarm)
    peer = PollTiming(ceiling=0.3, floor=0.01, swarm=swarm)
    assert newcomer.timeout == 0.3  # nobody answered yet
    peer.answered(0.02)
    peer.answered(0.001)
    assert newcomer.timeout == pytest.approx(0.04)  # twice the swarm's longest
    newcomer.timed_out(silent=True)  # probed alone from its first miss: the wait doubles
    assert newcomer.timeout == pytest.approx(0.08)
    newcomer.answered(0.002)  # its own answers rule from now on
    assert newcomer.timeout == 0.01
    newcomer.reset()  # restarted: the swarm's again
    assert newcomer.timeout == pytest.approx(0.04)


def test_the_price_of_a_poll_counts_a_lost_one_as_k_answered_ones() -> None:
    swarm = SwarmPollTimes()
    swarm.answered(0.001)
    timing = PollTiming(ceiling=0.3, floor=0.01, swarm=swarm)
    # not measured: the swarm's timeout (the floor) over the swarm's mean answer, K = 10
    assert timing.price(0.5) == pytest.approx(1 / (0.5 + 0.5 * 10))
    timing.answered(0.005)  # timeout 0.01: K = 2
    assert timing.price(1.0) == 1.0
    assert timing.price(0.5) == pytest.approx(1 / (0.5 + 0.5 * 2))
    timing.timed_out(silent=False)  # one in a row: the next answer is half as likely
    assert timing.price(1.0) == pytest.approx(1 / (0.5 + 0.5 * 2))
    fixed = PollTiming(ceiling=0.3, floor=0.3)  # a timeout as long as an answer: K = 1
    fixed.answered(0.3)
    assert fixed.price(0.2) == 1.0  # the paper's index, unchanged
