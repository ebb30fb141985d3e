"""Age of Information of one source: exact statistics of the sawtooth."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.core import AoITracker


def _two_steps() -> AoITracker:
    """start 0; update stamped 1 arrives at 2; update stamped 3 arrives at 4.

    A(t): 0 -> 2 on [0, 2], 1 -> 3 on [2, 4], 1 -> 2 on [4, 5]: area 2 + 4 + 1.5 = 7.5.
    """
    aoi = AoITracker(0.0)
    assert aoi.deliver(1.0, 2.0)
    assert aoi.deliver(3.0, 4.0)
    return aoi


def test_age_counts_from_start_before_the_first_delivery() -> None:
    aoi = AoITracker(10.0)
    assert aoi.age(10.0) == 0.0
    assert aoi.age(12.5) == 2.5
    assert aoi.mean(12.0) == pytest.approx(1.0)
    assert aoi.peak(12.0) == 2.0
    assert aoi.deliveries == 0


def test_hand_computed_sawtooth() -> None:
    aoi = _two_steps()
    assert aoi.age(5.0) == pytest.approx(2.0)
    assert aoi.mean(5.0) == pytest.approx(7.5 / 5.0)
    assert aoi.peak(5.0) == pytest.approx(3.0)
    assert aoi.deliveries == 2
    # time with A <= x: F(2) = 2 + 1 + 1 = 4 of 5 s, then only [2, 4] rises: F(x) = 4 + (x - 2)
    assert aoi.percentile(0.95, 5.0) == pytest.approx(2.75, rel=0.005, abs=1e-5)
    # below 1 only the first ramp counts, F(1) = 1; on [1, 2] all three: F = 1 + 3 (x - 1)
    assert aoi.percentile(0.5, 5.0) == pytest.approx(1.5, rel=0.005, abs=1e-5)
    assert aoi.percentile(0.0, 5.0) == pytest.approx(0.0, rel=0.005, abs=1e-5)
    assert aoi.percentile(1.0, 5.0) == pytest.approx(3.0, rel=0.005, abs=1e-5)


def test_periodic_sawtooth() -> None:
    """Updates stamped k = 1..10 arrive 0.5 s late: ramps 0.5 -> 1.5 after the first."""
    aoi = AoITracker(0.0)
    for k in range(1, 11):
        assert aoi.deliver(float(k), k + 0.5)
    now = 10.5
    assert aoi.mean(now) == pytest.approx((1.5**2 / 2 + 9 * 1.0) / now)
    assert aoi.peak(now) == pytest.approx(1.5)
    # F(x) = 9 (x - 0.5) + x on [0.5, 1.5]; F = 0.95 * 10.5  ->  x = 1.4475
    assert aoi.percentile(0.95, now) == pytest.approx(1.4475, rel=0.005, abs=1e-5)


def test_only_a_newer_time_stamp_lowers_the_age() -> None:
    aoi = _two_steps()
    before = (aoi.mean(6.0), aoi.percentile(0.95, 6.0), aoi.peak(6.0))
    assert not aoi.deliver(3.0, 4.5)  # same time-stamp again
    assert not aoi.deliver(2.0, 5.0)  # older
    assert aoi.deliveries == 2
    assert aoi.age(6.0) == pytest.approx(3.0)
    assert (aoi.mean(6.0), aoi.percentile(0.95, 6.0), aoi.peak(6.0)) == pytest.approx(before)


def test_update_generated_before_tracking_began_does_not_lower_the_age() -> None:
    aoi = AoITracker(5.0)
    aoi.deliver(4.0, 6.0)  # older than the start the age is counted from
    assert aoi.age(6.0) == 1.0
    assert aoi.mean(7.0) == pytest.approx(1.0)


def test_peak_remembers_the_highest_tooth() -> None:
    aoi = AoITracker(0.0)
    aoi.deliver(9.0, 10.0)
    aoi.deliver(10.5, 11.0)
    assert aoi.peak(11.2) == pytest.approx(10.0)
    assert aoi.peak(30.0) == pytest.approx(19.5)  # the open tooth overtakes it


def test_time_stamp_ahead_of_now_counts_as_now_and_cannot_hold_back_later_updates() -> None:
    """A stamp ahead of the delivery time (a follower clock estimated slightly ahead, or a
    forgery) gives age 0, never negative; it counts as generated at delivery, so an update
    stamped before that is not newer, and one generated after it is delivered."""
    aoi = AoITracker(0.0)
    assert aoi.deliver(3600.0, 4.0)
    assert aoi.age(4.0) == 0.0
    assert not aoi.deliver(3.9, 4.2)
    assert aoi.deliver(4.1, 4.2)
    assert aoi.age(4.5) == pytest.approx(0.4)
    assert aoi.deliveries == 2


def test_statistics_at_the_start() -> None:
    aoi = AoITracker(3.0)
    assert aoi.mean(3.0) == 0.0
    assert aoi.percentile(0.95, 3.0) == 0.0
    with pytest.raises(ValueError, match="q"):
        aoi.percentile(1.5, 4.0)


def test_percentiles_asked_between_deliveries_change_nothing() -> None:
    """The leader asks for percentiles while updates keep coming (its stats): asking
    leaves the statistics as they would be had nobody asked, at any later time."""
    asked, quiet = AoITracker(0.0), AoITracker(0.0)
    now = 0.0
    for step in range(1, 400):
        now += 0.001 * (1 + step % 7)
        stamp = now - 0.0004 * (step % 5)
        assert asked.deliver(stamp, now) == quiet.deliver(stamp, now)
        if step % 3 == 0:
            asked.percentile(0.95, now + 0.0005 * (step % 11))
    for q in (0.0, 0.5, 0.95, 1.0):
        assert asked.percentile(q, now + 0.002) == pytest.approx(
            quiet.percentile(q, now + 0.002), rel=1e-9, abs=1e-12)


def test_a_window_opened_mid_run_starts_at_the_age_it_finds() -> None:
    """Window [10, 14] opens with the freshest update 3 s old: A rises 3 -> 5 until an
    update stamped 11 arrives at 12, then 1 -> 3; an update older than the one before
    the window is not fresh."""
    aoi = AoITracker(10.0, initial_age=3.0)
    assert aoi.age(10.0) == 3.0
    assert not aoi.deliver(6.5, 11.0)
    assert aoi.deliver(11.0, 12.0)
    assert aoi.mean(14.0) == pytest.approx((8.0 + 4.0) / 4.0)
    assert aoi.peak(14.0) == pytest.approx(5.0)
    with pytest.raises(ValueError, match="initial_age"):
        AoITracker(0.0, initial_age=-1.0)
