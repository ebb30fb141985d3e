"""Ages in slots, as the policies read them: the scheduler computes them on every poll.

Each is the age a poll at ``now`` can remove (``sources.reducible_age``): the age of the
freshest delivered update for a source taken as always fresh (due = -inf, interval = 0,
the paper's assumption), 0 before a paced or phased source is due (nothing newer
ready), ``sqrt(A^2 - z^2)`` after, with ``z = (now - ready) mod interval`` (``ready`` is
a paced source's freshest generation time, a phased one's measured).
"""

from __future__ import annotations

from collections.abc import Sequence
from math import sqrt

import numpy as np

from wiswarm_zenoh.core.policies import FloatArray


def fresh_ages_in_slots(taus: Sequence[float], now: float, slot: float) -> list[float]:
    """``ages_in_slots`` where every source is taken as always fresh (the common case:
    one comprehension, no branch per follower)."""
    return [(now - tau) / slot if now > tau else 0.0 for tau in taus]


def ages_in_slots(taus: Sequence[float], dues: Sequence[float], intervals: Sequence[float],
                  readies: Sequence[float], now: float, slot: float) -> list[float]:
    """Each reducible age at ``now`` (0 for a time-stamp ahead of it), in slots; plain
    floats, no call per follower where its source is taken as always fresh (the
    scheduler runs this on every poll)."""
    ages = []
    for tau, due, interval, ready in zip(taus, dues, intervals, readies, strict=True):
        age = now - tau
        if age <= 0.0 or now < due:
            ages.append(0.0)
        elif interval > 0.0:
            z = (now - ready) % interval
            if z > age:
                z = age
            ages.append(sqrt(age * age - z * z) / slot)
        else:
            ages.append(age / slot)
    return ages


def array_fresh_ages_in_slots(taus: FloatArray, now: float, slot: float) -> FloatArray:
    """``array_ages_in_slots`` where every source is taken as always fresh (three numpy
    passes instead of seven: a thousand followers' pick runs on every poll)."""
    ages = now - taus
    np.maximum(ages, 0.0, out=ages)
    ages /= slot
    return ages


def array_ages_in_slots(taus: FloatArray, dues: FloatArray, intervals: FloatArray,
                        readies: FloatArray, now: float, slot: float) -> FloatArray:
    """``ages_in_slots`` for many followers, in one numpy pass (a new array)."""
    ages = np.maximum(now - taus, 0.0)
    modelled = intervals > 0.0
    if modelled.any():
        z = np.minimum(np.mod(now - readies, np.where(modelled, intervals, 1.0)), ages)
        ages = np.sqrt(ages * ages - np.where(modelled, z, 0.0) ** 2)
    ages[now < dues] = 0.0
    ages /= slot
    return ages
