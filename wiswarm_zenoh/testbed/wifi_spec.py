"""What a WiFi medium is (stations, 802.11 standard, data rate, lag limit) and what its
ns-3 scenario reports (per-node counters over a run's window): the plain values the
CLI, the study and the medium itself share, with no namespace or process behind them."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

STANDARDS = ("80211g", "80211n")
MAX_STATIONS = 30
ERP_MBPS = (6, 9, 12, 18, 24, 36, 48, 54)  # 802.11g's ERP-OFDM data rates
HT_20MHZ_MBPS = (6.5, 13.0, 19.5, 26.0, 39.0, 52.0, 58.5, 65.0)  # MCS 0-7, long guard
SATURATED_SHARE = 0.7


class MediumFailed(RuntimeError):
    """The ns-3 scenario ended under a run: lag beyond the hard limit, or a crash."""


@dataclass(frozen=True)
class WifiSpec:
    """The medium: stations, 802.11 standard, data rate (an ns-3 WifiMode name, None for
    the standard's default: 24 Mbit/s ERP-OFDM for g, HT MCS 7 for n) and the largest
    lag behind the wall clock the run tolerates."""

    stations: int = 4
    standard: str = "80211g"
    data_mode: str | None = None
    hard_limit_ms: float = 100.0

    @property
    def phy_rate_bps(self) -> float:
        """The data rate's bits/s on air (ErpOfdmRate<R>Mbps, HtMcs<k> at 20 MHz)."""
        mode = self.data_mode or ("ErpOfdmRate24Mbps" if self.standard == "80211g"
                                  else "HtMcs7")
        erp = re.fullmatch(r"ErpOfdmRate(\d+)Mbps", mode)
        if erp and int(erp.group(1)) in ERP_MBPS:
            return float(erp.group(1)) * 1e6
        ht = re.fullmatch(r"HtMcs(\d+)", mode)
        if ht and int(ht.group(1)) < len(HT_20MHZ_MBPS) and self.standard == "80211n":
            return HT_20MHZ_MBPS[int(ht.group(1))] * 1e6
        # Refused here, not by ns-3: a mode its PHY lacks ends the scenario.
        raise ValueError(f"data_mode {mode!r}: use ErpOfdmRate<R>Mbps, R one of "
                         f"{', '.join(map(str, ERP_MBPS))} (802.11g or n), or HtMcs0..HtMcs7 "
                         "(802.11n)")

    @property
    def capacity_bps(self) -> float:
        """Payload bits/s the air carries for saturated stations: a start for the
        best-rate search (measured: 16.8 of 24 Mbit/s for 802.11g), not a result."""
        return SATURATED_SHARE * self.phy_rate_bps

    def describe(self) -> str:
        return (f"ns-3 {self.standard} at 2.4 GHz, "
                f"{self.data_mode or 'default'} ({self.phy_rate_bps / 1e6:g} Mbit/s), "
                f"hard lag limit {self.hard_limit_ms:g} ms")

    def __post_init__(self) -> None:
        if not (isinstance(self.stations, int) and 1 <= self.stations <= MAX_STATIONS):
            raise ValueError(f"stations must be in [1, {MAX_STATIONS}], got {self.stations!r}")
        if self.standard not in STANDARDS:
            raise ValueError(f"standard must be one of {', '.join(STANDARDS)}, "
                             f"got {self.standard!r}")
        if not self.hard_limit_ms > 0:
            raise ValueError(f"hard_limit_ms must be > 0, got {self.hard_limit_ms!r}")
        _ = self.phy_rate_bps  # the data rate's own check, naming the field


@dataclass(frozen=True)
class MediumStats:
    """The scenario's last stats line: simulated time, largest lag, per-node counters
    (index 0 the access point)."""

    t: float
    max_lag_ms: float
    nodes: list[dict[str, float]] = field(default_factory=list)
    event: str = "stats"

    def total(self, name: str, stations_only: bool = False) -> float:
        return sum(node[name] for node in self.nodes[1 if stations_only else 0:])


def window_counters(first: MediumStats, last: MediumStats, span: float) -> dict[str, float]:
    """The medium over a run's window: frames each way per second, failed transmissions
    (not acknowledged: collisions and errors, each then retried) and their share of all
    transmissions, drops at the retry limit and at full queues, the air's busy share
    (every node's transmit time over the window) and the largest lag behind real time."""
    if not (first.nodes and last.nodes) or span <= 0:
        return {"max_lag_ms": last.max_lag_ms}

    def delta(name: str, stations_only: bool = False) -> float:
        return last.total(name, stations_only) - first.total(name, stations_only)

    acked, failed = delta("acked"), delta("nacked")
    return {
        "uplink_frames_per_s": delta("from_tap", stations_only=True) / span,
        "downlink_frames_per_s": (last.nodes[0]["from_tap"] - first.nodes[0]["from_tap"])
        / span,
        "failed_tx": failed,
        "failed_tx_share": failed / (acked + failed) if acked + failed else 0.0,
        "retry_drops": delta("drop_retry"),
        "queue_drops": delta("drop_queue"),
        "airtime_share": delta("tx_airtime_s") / span,
        "max_lag_ms": last.max_lag_ms,
    }
