"""The WiFi medium's plain parts, without root or ns-3: its spec's checks, its counters
over a window, and the command line's one-line refusals."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.testbed.wifi_spec import MediumStats, WifiSpec, window_counters


@pytest.mark.parametrize(("fields", "named"), [
    ({"stations": 0}, "stations"), ({"stations": 31}, "stations"),
    ({"standard": "80211b"}, "standard"), ({"hard_limit_ms": 0}, "hard_limit_ms")])
def test_a_bad_spec_names_its_field(fields: dict[str, object], named: str) -> None:
    with pytest.raises(ValueError, match=named):
        WifiSpec(**fields)  # type: ignore[arg-type]


def _node(from_tap: float, acked: float, nacked: float, airtime: float) -> dict[str, float]:
    return {"from_tap": from_tap, "acked": acked, "nacked": nacked, "drop_retry": 0.0,
            "drop_queue": 0.0, "tx_airtime_s": airtime}


def test_window_counters_are_differences_over_the_span() -> None:
    first = MediumStats(1.0, 0.5, [_node(10, 10, 0, 0.1), _node(100, 100, 10, 1.0)])
    last = MediumStats(3.0, 2.0, [_node(30, 30, 0, 0.2), _node(300, 280, 30, 2.0)])
    counters = window_counters(first, last, span=2.0)
    assert counters["uplink_frames_per_s"] == 100.0  # stations only
    assert counters["downlink_frames_per_s"] == 10.0
    assert counters["failed_tx"] == 20.0
    assert counters["failed_tx_share"] == pytest.approx(20 / (200 + 20))
    assert counters["airtime_share"] == pytest.approx(1.1 / 2.0)
    assert counters["max_lag_ms"] == 2.0


def test_no_window_keeps_only_the_lag() -> None:
    assert window_counters(MediumStats(0, 0), MediumStats(0, 1.5), 0.0) == {"max_lag_ms": 1.5}
