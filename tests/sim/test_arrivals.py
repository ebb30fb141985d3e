"""The slotted model with slow sources: the index on the age a poll can remove against
the paper's (``sim.arrivals``)."""

from __future__ import annotations

import dataclasses

from wiswarm_zenoh.sim.arrivals import ArrivalSpec, run_arrivals


def test_with_slow_sources_the_paced_index_serves_the_fast_ones_better_and_wastes_no_polls(
) -> None:
    spec = ArrivalSpec(n=8, slow=4, slow_interval=20.0, slots=8_000, paced=False)
    papers, paced = run_arrivals(spec), run_arrivals(dataclasses.replace(spec, paced=True))
    assert papers.empty_share > 0.2 and paced.empty_share < 0.05
    assert paced.fast_aoi < 0.85 * papers.fast_aoi
    assert paced.slow_aoi < papers.slow_aoi


def test_with_every_source_fast_the_two_indices_agree() -> None:
    spec = ArrivalSpec(n=6, slow=0, slots=5_000, paced=False)
    papers, paced = run_arrivals(spec), run_arrivals(dataclasses.replace(spec, paced=True))
    assert paced.empty_share <= 0.001 and papers.empty_share <= 0.001  # the very first polls
    assert abs(paced.fast_aoi - papers.fast_aoi) <= 0.02 * papers.fast_aoi
