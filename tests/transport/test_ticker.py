"""``Ticker``: a fixed-rate thread that survives a failing tick and skips missed ones."""

from __future__ import annotations

import threading

import pytest

from wiswarm_zenoh.programs.ticker import Ticker

from .helpers import WAIT


def test_ticks_carry_the_clock_and_a_failing_tick_does_not_stop_the_next() -> None:
    seen: list[float] = []
    third = threading.Event()

    def action(now: float) -> None:
        seen.append(now)
        if len(seen) == 3:
            third.set()
        if len(seen) == 1:
            raise RuntimeError("a bad frame")

    clock = iter(range(1000)).__next__
    ticker = Ticker(200.0, action, "test-ticker", clock=lambda: float(clock()))
    ticker.start()
    try:
        assert third.wait(WAIT)
    finally:
        ticker.stop()
    assert seen[:3] == [0.0, 1.0, 2.0]
    assert ticker.ticks == len(seen)


def test_a_late_tick_skips_the_ticks_it_missed_instead_of_bursting() -> None:
    release, later = threading.Event(), threading.Event()
    calls: list[float] = []

    def action(now: float) -> None:
        calls.append(now)
        if len(calls) == 1:
            release.wait(WAIT)  # the first tick overruns 100 periods or so
        elif len(calls) == 2:
            later.set()

    ticker = Ticker(1000.0, action, "test-ticker")
    ticker.start()
    try:
        threading.Timer(0.1, release.set).start()
        assert later.wait(WAIT)
        ticks_right_after = ticker.ticks
    finally:
        ticker.stop()
    assert ticks_right_after <= 10  # a burst would have run ~100 ticks at once


@pytest.mark.parametrize("rate", [0.0, -1.0, 20_000.0])
def test_rates_out_of_range_are_refused(rate: float) -> None:
    with pytest.raises(ValueError, match="rate_hz"):
        Ticker(rate, lambda now: None, "test-ticker")
