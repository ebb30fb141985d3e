"""Runs over the 802.11 channel: WiSwarm scales linearly, fixed-rate UDP explodes past
capacity, TCP is reliable, and the same seed gives the same run."""

from __future__ import annotations

import numpy as np
import pytest

from wiswarm_zenoh.core.config import FollowerConfig
from wiswarm_zenoh.sim.phy import Airtime, WifiParams
from wiswarm_zenoh.sim.scenario import PAPER_FRAME_BYTES, WifiScenario, run_wifi


def _aoi(**kwargs: object) -> float:
    return run_wifi(WifiScenario(**kwargs)).mean("mean_aoi_s")  # type: ignore[arg-type]


def test_wiswarm_aoi_grows_about_linearly_with_n() -> None:
    ns = np.array([2, 4, 8, 16])
    aoi = np.array([_aoi(n=int(n), system="wiswarm", duration=8.0, seed=1) for n in ns])
    slope, intercept = np.polyfit(ns, aoi, 1)
    residual = aoi - (slope * ns + intercept)
    assert slope > 0
    assert np.max(np.abs(residual)) < 0.05 * aoi[-1]
    # Each follower adds about one poll cycle: a frame's airtime plus the poll overhead.
    frame = Airtime(WifiParams()).frame_airtime(PAPER_FRAME_BYTES)
    assert frame / 2 < slope < frame


def test_fixed_rate_udp_explodes_once_the_offered_load_passes_capacity() -> None:
    capacity_fps = 1.0 / Airtime(WifiParams()).frame_airtime(PAPER_FRAME_BYTES)
    rate = 50.0
    assert rate < capacity_fps < 2 * rate  # one UAV fits, two do not
    below = _aoi(n=1, system="udp", rate=rate, duration=10.0, seed=2)
    assert below < 0.1
    above_short = _aoi(n=4, system="udp", rate=rate, duration=10.0, seed=2)
    above_long = _aoi(n=4, system="udp", rate=rate, duration=20.0, seed=2)
    wiswarm = _aoi(n=4, system="wiswarm", duration=10.0, seed=2)
    assert above_short > 30 * wiswarm
    assert above_long > 1.7 * above_short  # the FIFO backlog grows with time


def test_tcp_delivers_every_frame_over_lossy_links_where_udp_loses_some() -> None:
    common = {"n": 2, "rate": 5.0, "duration": 20.0, "seed": 3, "reliability": (0.35, 0.4)}
    tcp = run_wifi(WifiScenario(system="tcp", **common))  # type: ignore[arg-type]
    udp = run_wifi(WifiScenario(system="udp", **common))  # type: ignore[arg-type]
    generated = 5.0 * 20.0
    # ~5 % of MAC frames exhaust their retries: a 34-fragment datagram rarely survives,
    # while TCP resends the lost segments (what is missing is still in flight at the end).
    assert all(f.deliveries >= 0.85 * generated for f in tcp.followers)
    assert all(f.deliveries <= 0.5 * generated for f in udp.followers)


def test_wiswarm_recovers_from_lost_polls_and_replies_by_timeout() -> None:
    # Bad links and 8 kB fragments: the core resends unacknowledged fragments on later polls.
    scenario = WifiScenario(
        n=3, duration=20.0, seed=4, reliability=(0.4, 0.45),
        follower_config=FollowerConfig(fragment_size=8192),
    )
    result = run_wifi(scenario)
    assert result.channel["timeouts"] > 0
    assert result.channel["polls"] > result.channel["timeouts"]
    assert all(f.deliveries >= 10 for f in result.followers)  # 7 fragments each
    assert result.mean("peak_aoi_s") < 5.0


def test_the_same_seed_gives_the_same_run_and_another_seed_does_not() -> None:
    def run(seed: int, system: str) -> dict[str, object]:
        scenario = WifiScenario(n=3, system=system, rate=20.0, duration=3.0, seed=seed)
        return run_wifi(scenario).as_dict()

    for system in ("wiswarm", "udp", "tcp"):
        assert run(5, system) == run(5, system)
        assert run(5, system)["followers"] != run(6, system)["followers"]


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"n": 0}, "n"),
        ({"n": 2, "rate": -5.0}, "rate"),
        ({"n": 2, "system": "quic"}, "system"),
        ({"n": 2, "frame_bytes": 17 * 1024 * 1024}, "frame_bytes"),
        ({"n": 2, "reliability": (0.0, 0.5)}, "reliability"),
        ({"n": 2, "duration": 0.0}, "duration"),
        ({"n": 2, "policy": "nope"}, "policy"),
    ],
)
def test_impossible_parameters_are_refused(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        WifiScenario(**kwargs)  # type: ignore[arg-type]
