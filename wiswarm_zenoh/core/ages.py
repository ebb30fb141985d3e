"""Ages in slots, as the policies read them: the scheduler computes them on every poll."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wiswarm_zenoh.core.policies import FloatArray


def ages_in_slots(taus: Sequence[float], now: float, slot: float) -> list[float]:
    """Each age at ``now`` (0 for a time-stamp ahead of it), in slots; plain floats, no
    ``max`` call per follower (the scheduler runs this on every poll)."""
    return [(now - tau) / slot if now > tau else 0.0 for tau in taus]


def array_ages_in_slots(taus: FloatArray, now: float, slot: float) -> FloatArray:
    """``ages_in_slots`` for many followers, in one numpy pass (a new array)."""
    ages = np.maximum(now - taus, 0.0)
    ages /= slot
    return ages
