"""Link reliability (answered share of the last W polls) and the weight EMA."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wiswarm_zenoh.core.estimators import ReliabilityEstimator, WeightEMA


def test_reliability_uses_the_prior_until_the_window_is_full() -> None:
    est = ReliabilityEstimator(window=4, prior=0.5)
    assert est.value == 0.5
    expected = [(1 + 1.5) / 4, (1 + 1.0) / 4, (2 + 0.5) / 4, 3 / 4]
    for answered, value in zip([True, False, True, True], expected, strict=True):
        est.record(answered)
        assert est.value == pytest.approx(value)


def test_reliability_window_slides() -> None:
    est = ReliabilityEstimator(window=4, prior=1.0)
    for answered in [True, False, True, True]:
        est.record(answered)
    est.record(False)  # evicts the first True: F T T F
    assert est.value == pytest.approx(0.5)
    est.record(False)  # evicts F: T T F F
    assert est.value == pytest.approx(0.5)
    est.record(False)  # evicts T: T F F F
    assert est.value == pytest.approx(0.25)
    for _ in range(4):
        est.record(True)
    assert est.value == 1.0


def test_reliability_window_of_one_is_the_last_outcome() -> None:
    est = ReliabilityEstimator(window=1, prior=0.0)
    assert est.value == 0.0
    est.record(True)
    assert est.value == 1.0
    est.record(False)
    assert est.value == 0.0


@pytest.mark.parametrize(("window", "prior", "field"), [(0, 1.0, "window"), (3, 1.5, "prior"),
                                                        (3, -0.1, "prior")])
def test_reliability_rejects_bad_settings(window: int, prior: float, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        ReliabilityEstimator(window, prior)


def test_weight_ema() -> None:
    ema = WeightEMA(alpha=0.8, initial=1.0)
    assert ema.observe(6.0) == pytest.approx(2.0)
    assert ema.observe(6.0) == pytest.approx(2.8)
    for _ in range(200):
        ema.observe(6.0)
    assert ema.value == pytest.approx(6.0)


def test_weight_ema_extreme_alphas() -> None:
    frozen, instant = WeightEMA(alpha=1.0, initial=3.0), WeightEMA(alpha=0.0, initial=3.0)
    assert frozen.observe(10.0) == 3.0
    assert instant.observe(10.0) == 10.0
    assert instant.observe(0.0) == 0.0


@pytest.mark.parametrize("v", [-1.0, math.nan, math.inf])
def test_weight_ema_rejects_bad_urgency(v: float) -> None:
    ema = WeightEMA()
    with pytest.raises(ValueError, match="urgency"):
        ema.observe(v)
    assert ema.value == 1.0


@pytest.mark.parametrize("alpha", [-0.01, 1.01])
def test_weight_ema_rejects_bad_alpha(alpha: float) -> None:
    with pytest.raises(ValueError, match="alpha"):
        WeightEMA(alpha)


@settings(deadline=None)  # no time bound: a busy machine may hold any example up
@given(window=st.integers(1, 6), prior=st.floats(0.0, 1.0),
       outcomes=st.lists(st.booleans(), max_size=20), last=st.booleans())
def test_reliability_after_foretells_record(window: int, prior: float, outcomes: list[bool],
                                            last: bool) -> None:
    estimator = ReliabilityEstimator(window, prior)
    for answered in outcomes:
        estimator.record(answered)
    before = estimator.value
    foretold = estimator.after(last)
    assert estimator.value == before  # only foretold
    estimator.record(last)
    assert estimator.value == pytest.approx(foretold)


def test_an_outage_forgotten_leaves_the_link_s_record_before_it() -> None:
    r = ReliabilityEstimator(window=4, prior=1.0)
    for answered in (True, False, True, False, False):
        r.record(answered)
    assert r.value == 0.25  # the window holds F T F F
    r.forget_outage()  # the two misses since the last answer: the process was gone
    assert r.value == pytest.approx((1 + 2 * 1.0) / 4)  # F T kept, two polls at the prior
    r.record(False)
    assert r.value == pytest.approx((1 + 1 * 1.0) / 4)  # F T F


def test_an_outage_forgotten_gives_one_that_never_answered_a_newcomer_s_prior() -> None:
    r = ReliabilityEstimator(window=4, prior=0.5)
    r.record(False)
    r.record(False)
    assert r.value == 0.0
    r.forget_outage()
    assert r.value == 0.5
    r.record(True)
    assert r.value == pytest.approx((1 + 0.5 * 3) / 4)
