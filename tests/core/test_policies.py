"""Scheduling policies: index formulas, deterministic ties, the general cost f(A)."""

from __future__ import annotations

import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wiswarm_zenoh.core.policies import (
    LINEAR_COST,
    POLICIES,
    AgeCost,
    Whittle,
    make_policy,
    power_cost,
)


def _a(*values: float) -> np.ndarray:
    return np.array(values, dtype=np.float64)


ONES = _a(1.0, 1.0, 1.0)


def test_registry_names() -> None:
    assert set(POLICIES) == {
        "whittle", "whittle-exact", "max-weight", "max-age", "round-robin", "random",
    }
    for name in POLICIES:
        assert make_policy(name, random.Random(0)).name == name


def test_unknown_policy_lists_the_allowed_names() -> None:
    with pytest.raises(ValueError, match=r"policy must be one of .*'whittle'.*got 'fastest'"):
        make_policy("fastest")


@pytest.mark.parametrize(("name", "w", "p", "h", "expected"), [
    # whittle w p h^2: 1*1*4 = 4 vs 3*0.5*4 = 6 vs 1*1*9 = 9
    ("whittle", ONES, ONES, _a(2, 1, 3), 2),
    ("whittle", _a(1, 3, 1), _a(1, 0.5, 1), _a(2, 2, 2.3), 1),
    # whittle-exact w p h (h + 2/p - 1): 2*3 = 6 vs 0.1*3*(3+19) = 6.6 (whittle: 4 vs 0.9)
    ("whittle-exact", _a(1, 1), _a(1, 0.1), _a(2, 3), 1),
    ("whittle", _a(1, 1), _a(1, 0.1), _a(2, 3), 0),
    # max-weight w p h (h + 2): 1*3 = 3 vs 0.5*1.5*3.5 = 2.625 (whittle: 1 vs 1.125)
    ("max-weight", _a(1, 1), _a(1, 0.5), _a(1, 1.5), 0),
    ("whittle", _a(1, 1), _a(1, 0.5), _a(1, 1.5), 1),
    # max-age ignores weights and reliabilities
    ("max-age", _a(100, 1), _a(1, 0.01), _a(1, 1.5), 1),
])
def test_index_formulas(name: str, w: np.ndarray, p: np.ndarray, h: np.ndarray,
                        expected: int) -> None:
    assert make_policy(name).choose(w, p, h) == expected


@pytest.mark.parametrize("name", ["whittle", "whittle-exact", "max-weight", "max-age"])
def test_ties_go_to_the_lowest_index(name: str) -> None:
    policy = make_policy(name)
    assert policy.choose(_a(1, 2, 2, 1), _a(1, 1, 1, 1), _a(3, 3, 3, 3)) == (
        0 if name == "max-age" else 1
    )
    zeros = np.zeros(5)
    assert policy.choose(np.ones(5), np.ones(5), zeros) == 0
    for _ in range(3):  # stateless: the same arrays give the same answer
        assert policy.choose(_a(1, 1, 1), _a(1, 1, 1), _a(1, 4, 4)) == 1


def test_round_robin_cycles_in_index_order_and_follows_resizes() -> None:
    policy = make_policy("round-robin")
    picks = [policy.choose(ONES, ONES, _a(0, 0, 9)) for _ in range(7)]
    assert picks == [0, 1, 2, 0, 1, 2, 0]
    assert policy.choose(np.ones(2), np.ones(2), np.zeros(2)) == 1
    assert policy.choose(np.ones(2), np.ones(2), np.zeros(2)) == 0


def test_random_is_uniform_and_reproducible_from_the_injected_rng() -> None:
    n = 4
    draws = [make_policy("random", random.Random(42)).choose(*([np.ones(n)] * 3))
             for _ in range(3)]
    assert len(set(draws)) == 1
    policy = make_policy("random", random.Random(5))
    counts = np.bincount([policy.choose(*([np.ones(n)] * 3)) for _ in range(4000)], minlength=n)
    assert counts.min() > 900 and counts.max() < 1100


def test_whittle_with_power_cost_one_matches_the_linear_fast_path() -> None:
    gen = np.random.default_rng(1)
    linear, general = Whittle(), Whittle(power_cost(1.0))
    for _ in range(200):
        w, p, h = gen.uniform(0.1, 5, 50), gen.uniform(0.05, 1, 50), gen.uniform(0, 100, 50)
        assert linear.choose(w, p, h) == general.choose(w, p, h)


def test_general_cost_changes_the_choice() -> None:
    """f(A) = A^k gives index 2 w p k/(k+1) A^(k+1): a steeper cost favours the oldest."""
    w, p, h = _a(1, 10), _a(1, 1), _a(10, 4)
    assert Whittle().choose(w, p, h) == 1  # 100 vs 160
    assert Whittle(power_cost(3.0)).choose(w, p, h) == 0  # 1.5e4 vs 3.84e3
    # a flatter cost favours the heavier one: 10^1.5 = 31.6 vs 3 * 5^1.5 = 33.5 (linear 100 vs 75)
    assert Whittle().choose(_a(1, 3), p, _a(10, 5)) == 0
    assert Whittle(power_cost(0.5)).choose(_a(1, 3), p, _a(10, 5)) == 1


def test_step_cost_uses_the_given_integral() -> None:
    """f(A) = 1 above a deadline D, else 0; F(A) = max(A - D, 0): index 2 w p D [A > D]."""
    deadline = 5.0
    step = AgeCost(
        f=lambda a: (a > deadline).astype(np.float64),
        integral=lambda a: np.maximum(a - deadline, 0.0),
    )
    policy = Whittle(step)
    assert policy.choose(_a(1, 1, 1), _a(1, 1, 1), _a(4, 6, 100)) == 1  # equal past D: lowest
    assert policy.choose(_a(1, 1, 2), _a(1, 1, 1), _a(4, 6, 5.5)) == 2
    assert Whittle(LINEAR_COST).choose(_a(1, 1, 2), _a(1, 1, 1), _a(4, 6, 5.5)) == 2


@pytest.mark.parametrize("k", [0.0, -1.0])
def test_power_cost_rejects_non_positive_exponents(k: float) -> None:
    with pytest.raises(ValueError, match="exponent"):
        power_cost(k)


@pytest.mark.parametrize("name", sorted(POLICIES))
def test_every_policy_picks_a_valid_index_on_large_random_arrays(name: str) -> None:
    gen = np.random.default_rng(9)
    policy = make_policy(name, random.Random(9))
    for n in (1, 2, 1000):
        w, p, h = gen.uniform(0.1, 5, n), gen.uniform(0.05, 1, n), gen.uniform(0, 50, n)
        assert 0 <= policy.choose(w, p, h) < n


small = st.integers(0, 4).map(float)  # few distinct values: ties are common


@settings(max_examples=300, derandomize=True, deadline=None)
@given(st.sampled_from(["whittle", "whittle-exact", "max-weight", "max-age", "power-2"]),
       st.lists(st.tuples(small, small.map(lambda v: (v + 1) / 5), small), min_size=1,
                max_size=20))
def test_the_plain_float_path_picks_what_the_numpy_path_picks(
        name: str, rows: list[tuple[float, float, float]]) -> None:
    policy = Whittle(power_cost(2.0)) if name == "power-2" else make_policy(name)
    w, p, h = (list(column) for column in zip(*rows, strict=True))
    assert policy.choose_in_lists(w, p, h) == policy.choose(_a(*w), _a(*p), _a(*h))
