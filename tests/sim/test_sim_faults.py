"""Faults in the simulator (slotted and 802.11 models): the priced index against the paper's."""

from __future__ import annotations

import dataclasses
from statistics import mean

import pytest

from wiswarm_zenoh.sim.faults import FaultSpec, run_faults
from wiswarm_zenoh.sim.scenario import WifiScenario, run_wifi


def test_where_a_timeout_costs_one_slot_the_priced_index_is_the_papers() -> None:
    spec = FaultSpec(dead=1, intermittent=1, timeout_slots=1.0, slots=5_000, priced=False)
    assert run_faults(dataclasses.replace(spec, priced=True)) == run_faults(spec)


def test_with_dead_followers_and_costly_timeouts_the_priced_index_ages_less() -> None:
    ratios = []
    for seed in range(5):
        spec = FaultSpec(dead=3, timeout_slots=100.0, slots=20_000, seed=seed, priced=False)
        ratios.append(run_faults(dataclasses.replace(spec, priced=True)) / run_faults(spec))
    assert mean(ratios) < 0.95


def test_a_swarm_of_only_dead_followers_is_refused() -> None:
    with pytest.raises(ValueError, match="alive"):
        FaultSpec(n=2, dead=2)


def _live_mean_aoi(dead: int, priced: bool) -> float:
    result = run_wifi(WifiScenario(n=8, duration=8.0, dead=dead, price_by_time=priced,
                                   adaptive_timeout=False))
    return mean(f.mean_aoi_s for f in result.followers[dead:])


def test_over_wifi_a_dead_follower_costs_the_others_less_with_the_priced_index() -> None:
    """The 802.11 model: a dead follower's link delivers nothing from 1 s on, each of its
    polls waits out the paper's fixed timeout (0.3 s, some 20 polls' time), which the
    paper's index ignores. (With adaptive timeouts a poll of a follower that just died
    costs twice its answered polls' time, and both indices lose little.)"""
    assert _live_mean_aoi(1, priced=True) < 0.8 * _live_mean_aoi(1, priced=False)
    # where nothing fails, pricing changes nothing
    assert _live_mean_aoi(0, priced=True) == pytest.approx(_live_mean_aoi(0, priced=False),
                                                           rel=0.03)


def test_a_wifi_run_with_every_follower_dead_is_refused() -> None:
    with pytest.raises(ValueError, match="dead"):
        WifiScenario(n=2, dead=2)
