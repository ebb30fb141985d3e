"""Configuration validation: ValueError naming the field and the allowed values."""

from __future__ import annotations

import math
from typing import Any

import pytest

from wiswarm_zenoh.core import FollowerConfig, Leader, LeaderConfig
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES


def test_defaults_are_valid_and_match_the_design() -> None:
    f, lc = FollowerConfig(), LeaderConfig()
    assert (f.queue, f.capacity, f.drop, f.rate_hz) == ("lifo", 1, "tail", None)
    assert (lc.policy, lc.timeout, lc.window, lc.prior_p, lc.alpha) == (
        "whittle", 0.3, 20, 1.0, 0.8
    )


@pytest.mark.parametrize(("field", "value", "allowed"), [
    ("window", 0, ">= 1"),
    ("window", -3, ">= 1"),
    ("alpha", -0.1, "[0, 1]"),
    ("alpha", 1.5, "[0, 1]"),
    ("alpha", math.nan, "[0, 1]"),
    ("policy", "fastest", "whittle"),
    ("timeout", 0.0, "> 0"),
    ("timeout", math.inf, "> 0"),
    ("prior_p", 1.1, "[0, 1]"),
    ("probe_interval", 0.0, "> 0 seconds"),
    ("probe_max", 0.1, ">= probe_interval"),
    ("initial_weight", 0.0, "> 0"),
    ("weight_floor", -1.0, ">= 0"),
    ("max_fragments", 0, ">= 1"),
    ("max_update_bytes", 0, ">= 1"),
    ("clock_samples", 0, ">= 1"),
])
def test_leader_config_names_the_bad_field(field: str, value: Any, allowed: str) -> None:
    with pytest.raises(ValueError, match=field) as info:
        LeaderConfig(**{field: value})
    assert allowed in str(info.value)


@pytest.mark.parametrize(("field", "value", "allowed"), [
    ("fragment_size", FRAGMENT_HEADER_BYTES, "header"),
    ("fragment_size", 10, "header"),
    ("queue", "stack", "'lifo' or 'fifo'"),
    ("capacity", 0, ">= 1"),
    ("drop", "middle", "'tail' or 'head'"),
    ("rate_hz", 0.0, "> 0"),
    ("rate_hz", math.inf, "> 0"),
    ("max_update_bytes", 0, ">= 1"),
    ("abandon_after", -1.0, ">= 0"),
    ("abandon_after", math.nan, ">= 0"),
    ("control_window", 0.0, "> 0 seconds"),
    ("control_window", math.inf, "> 0 seconds"),
    ("poller_expiry", math.nan, "> 0 seconds"),
])
def test_follower_config_names_the_bad_field(field: str, value: Any, allowed: str) -> None:
    with pytest.raises(ValueError, match=field) as info:
        FollowerConfig(**{field: value})
    assert allowed in str(info.value)


def test_boundary_values_are_accepted() -> None:
    FollowerConfig(fragment_size=FRAGMENT_HEADER_BYTES + 1, abandon_after=0.0, rate_hz=1e-3)
    LeaderConfig(window=1, alpha=0.0, prior_p=0.0, probe_interval=1.0, probe_max=1.0,
                 weight_floor=0.0)
    LeaderConfig(alpha=1.0)


def test_leader_uses_the_configured_policy() -> None:
    assert Leader(LeaderConfig(policy="max-age")).policy.name == "max-age"
