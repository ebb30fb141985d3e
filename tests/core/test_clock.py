"""Clock offset from NTP's four time-stamps, filtered by the minimum round-trip delay."""

from __future__ import annotations

import random

import pytest

from wiswarm_zenoh.core.clock import ClockOffsetEstimator

OFFSET = 5.0  # the follower's clock runs 5 s ahead of the leader's


def _sample(t1: float, up: float, down: float, hold: float = 0.0005) -> tuple[float, ...]:
    """Stamps of one poll: sent at t1 (leader), ``up`` and ``down`` one-way delays."""
    t2 = t1 + up + OFFSET
    t3 = t2 + hold
    t4 = t3 - OFFSET + down
    return t1, t2, t3, t4


def test_symmetric_delay_gives_the_exact_offset() -> None:
    est = ClockOffsetEstimator()
    est.add(*_sample(100.0, 0.002, 0.002))
    assert est.offset == pytest.approx(OFFSET)
    assert est.delay == pytest.approx(0.004)
    assert est.to_leader(105.5) == pytest.approx(100.5)


def test_asymmetric_delay_errs_by_half_the_asymmetry() -> None:
    est = ClockOffsetEstimator()
    est.add(*_sample(0.0, 0.010, 0.002))
    assert est.offset == pytest.approx(OFFSET + 0.004)


def test_min_delay_filter_picks_the_least_queued_sample() -> None:
    rng = random.Random(3)
    est = ClockOffsetEstimator(samples=8)
    t = 0.0
    for i in range(8):
        t += 0.1
        if i == 5:
            est.add(*_sample(t, 0.001, 0.001))  # the one clean exchange
        else:  # queueing on one leg only: delay and offset error grow together
            est.add(*_sample(t, 0.001 + rng.expovariate(1 / 0.02), 0.001))
    assert est.offset == pytest.approx(OFFSET)
    assert est.delay == pytest.approx(0.002)


def test_jittered_delays_keep_the_error_within_half_the_best_delay() -> None:
    rng = random.Random(11)
    est = ClockOffsetEstimator(samples=8)
    for k in range(200):
        up = 0.001 + rng.expovariate(1 / 0.01)
        down = 0.001 + rng.expovariate(1 / 0.03)
        est.add(*_sample(k * 0.05, up, down))
        assert est.delay is not None
        assert abs(est.offset - OFFSET) <= est.delay / 2 + 1e-12
    # with exponential jitter some recent sample is nearly clean
    assert abs(est.offset - OFFSET) < 0.01


def test_old_samples_leave_the_window() -> None:
    est = ClockOffsetEstimator(samples=2)
    est.add(*_sample(0.0, 0.001, 0.001))
    est.add(*_sample(1.0, 0.030, 0.010))
    est.add(*_sample(2.0, 0.020, 0.010))
    assert est.delay == pytest.approx(0.030)
    assert est.offset == pytest.approx(OFFSET + 0.005)


def test_inconsistent_stamps_are_ignored() -> None:
    est = ClockOffsetEstimator()
    est.add(0.0, 10.0, 9.0, 1.0)  # follower sent before it received
    est.add(1.0, 6.0, 6.0, 0.5)  # leader received before it sent
    est.add(0.0, 5.0, 5.9, 0.5)  # follower held it longer than the round trip
    assert est.delay is None
    assert est.offset == 0.0
    assert est.to_leader(3.0) == 3.0


def test_reset_forgets_samples() -> None:
    est = ClockOffsetEstimator()
    est.add(*_sample(0.0, 0.001, 0.001))
    est.reset()
    assert (est.offset, est.delay) == (0.0, None)


def test_rejects_an_empty_window() -> None:
    with pytest.raises(ValueError, match="samples"):
        ClockOffsetEstimator(samples=0)


def test_synchronised_clocks_with_asymmetric_paths_are_taken_as_synchronised() -> None:
    est = ClockOffsetEstimator()
    # same clock, tiny poll (0.1 ms up), large reply (7 ms down): the raw estimate is
    # -3.45 ms, within half the delay of zero, so no correction is applied
    est.add(10.0, 10.0001, 10.0002, 10.0072)
    assert est.delay == pytest.approx(0.0071)
    assert est.offset == 0.0


def test_an_offset_beyond_half_the_delay_is_still_corrected() -> None:
    est = ClockOffsetEstimator()
    est.add(10.0, 10.0101, 10.0102, 10.0003)  # clock 10 ms ahead, 0.1 ms each way
    assert est.offset == pytest.approx(0.010)


def test_stamps_no_clock_gives_are_judged_and_leave_the_estimate_alone() -> None:
    est = ClockOffsetEstimator(samples=3)
    assert est.judge(10.0, 10.0101, 10.0102, 10.0003) is None  # nothing known: any clock
    est.add(10.0, 10.0101, 10.0102, 10.0003)
    assert "out of order" in str(est.judge(11.0, 11.02, 11.0, 11.001))  # sent before received
    assert "off this follower's clock" in str(est.judge(11.0, 3611.0, 3611.0, 11.001))
    assert est.judge(11.0, 11.0102, 11.0103, 11.0004) is None  # the same clock, 10 ms ahead
    assert est.offset == pytest.approx(0.010)


def test_a_clock_that_really_stepped_is_taken_after_samples_refused_polls() -> None:
    est = ClockOffsetEstimator(samples=3)
    est.add(10.0, 10.0001, 10.0002, 10.0003)
    stepped = (11.0, 3611.0001, 3611.0002, 11.0003)  # the follower's clock jumped an hour
    for _ in range(2):
        assert est.judge(*stepped) is not None
        est.refused()
    assert est.judge(*stepped) is None  # the third poll in a row: re-anchor
    est.add(*stepped)
    assert est.offset == pytest.approx(3600.0)
    assert est.refused_in_a_row == 0
