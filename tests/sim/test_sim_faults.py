"""The slotted model with faults: the priced index against the paper's."""

from __future__ import annotations

import dataclasses
from statistics import mean

import pytest

from wiswarm_zenoh.sim.faults import FaultSpec, run_faults


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
