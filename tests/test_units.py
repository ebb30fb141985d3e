"""Rates and times as written on command lines (``20mbit``, ``200ms``)."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.units import format_rate, parse_rate, parse_seconds


@pytest.mark.parametrize(("text", "bps"), [("20mbit", 20_000_000), ("5MBIT", 5_000_000),
                                           ("1.5mbit", 1_500_000), ("500kbit", 500_000),
                                           ("1gbit", 10**9), ("64000", 64_000)])
def test_rates_in_tc_spelling(text: str, bps: int) -> None:
    assert parse_rate(text) == bps
    assert parse_rate(format_rate(bps)) == bps


@pytest.mark.parametrize("text", ["0", "0mbit", "fast", "-3mbit", "20 mbits", "", "1e9"])
def test_bad_rates_say_what_is_wrong(text: str) -> None:
    with pytest.raises(ValueError, match="rate"):
        parse_rate(text)


def test_times() -> None:
    assert parse_seconds("200ms") == pytest.approx(0.2)
    assert parse_seconds("2") == 2.0
    assert parse_seconds("50us") == pytest.approx(5e-5)
    for bad in ("0ms", "soon", "-1s"):
        with pytest.raises(ValueError, match="time"):
            parse_seconds(bad)
