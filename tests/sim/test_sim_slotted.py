"""The slotted model against theory (Kadota et al.), with the core's own policies."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.core.policies import POLICIES
from wiswarm_zenoh.sim.metrics import lower_bound
from wiswarm_zenoh.sim.slotted import SlottedSpec, run_slotted


def test_round_robin_matches_its_closed_form_per_follower() -> None:
    n = 10
    result = run_slotted(SlottedSpec(n=n, policy="round-robin", seed=4, slots=200_000))
    for p, aoi in zip(result.p, result.mean_aoi, strict=True):
        assert aoi == pytest.approx(n * (2 - p) / (2 * p) + 0.5, rel=0.02)


@pytest.mark.parametrize("p", [0.5, 0.9])
def test_max_age_in_a_symmetric_network_matches_its_closed_form(p: float) -> None:
    n = 12
    spec = SlottedSpec(n=n, policy="max-age", seed=5, weights=(1, 1), reliability=(p, p))
    result = run_slotted(spec)
    assert result.ewsaoi == pytest.approx((n + 1) / (2 * p), rel=0.02)


@pytest.mark.parametrize("policy", sorted(POLICIES))
def test_no_policy_beats_the_lower_bound(policy: str) -> None:
    for n, seed in [(1, 1), (3, 2), (14, 3)]:
        result = run_slotted(SlottedSpec(n=n, policy=policy, seed=seed, slots=20_000))
        assert result.ewsaoi >= result.lower_bound
        assert result.ratio == pytest.approx(result.ewsaoi / result.lower_bound)


def test_whittle_comes_within_four_percent_of_the_bound_at_n14() -> None:
    ratios = [run_slotted(SlottedSpec(n=14, policy="whittle", seed=s)).ratio for s in (0, 1, 2)]
    assert all(1.0 <= r <= 1.04 for r in ratios), ratios


def test_lower_bound_formula() -> None:
    # Two followers: (sqrt(1/0.5) + sqrt(4/1))^2 / 4 + 5/4.
    assert lower_bound([1.0, 4.0], [0.5, 1.0]) == pytest.approx((2**0.5 + 2) ** 2 / 4 + 1.25)


def test_the_same_seed_gives_the_same_result_and_another_seed_does_not() -> None:
    a = run_slotted(SlottedSpec(n=6, policy="random", seed=9, slots=5000))
    b = run_slotted(SlottedSpec(n=6, policy="random", seed=9, slots=5000))
    c = run_slotted(SlottedSpec(n=6, policy="random", seed=10, slots=5000))
    assert a == b
    assert a.ewsaoi != c.ewsaoi


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"n": 0}, "n"),
        ({"n": 3, "reliability": (0.0, 1.0)}, "reliability"),
        ({"n": 3, "reliability": (0.5, 1.2)}, "reliability"),
        ({"n": 3, "weights": (3.0, 1.0)}, "weights"),
        ({"n": 3, "policy": "fastest"}, "policy"),
        ({"n": 3, "slots": 0}, "slots"),
    ],
)
def test_impossible_parameters_are_refused(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        SlottedSpec(**kwargs)  # type: ignore[arg-type]
