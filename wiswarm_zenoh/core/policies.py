"""Scheduling policies: who to poll next, given weights w, reliabilities p and ages h.

Every policy works on numpy arrays in one vectorised pass and breaks ties
deterministically (lowest index, i.e. the follower that joined first), except
``random``, whose randomness comes from the injected generator.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
ArrayFn = Callable[[FloatArray], FloatArray]


class Policy(Protocol):
    """Picks the index of the follower to poll; arrays have one entry per follower."""

    name: str

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int: ...


@dataclass(frozen=True)
class AgeCost:
    """A non-decreasing cost f(A) of age and its integral F(A) = int_0^A f (F(0) = 0)."""

    f: ArrayFn
    integral: ArrayFn


LINEAR_COST = AgeCost(f=lambda a: a, integral=lambda a: 0.5 * a * a)


def power_cost(k: float) -> AgeCost:
    """f(A) = A^k, for k > 0."""
    if not k > 0:
        raise ValueError(f"power cost exponent must be > 0, got {k}")
    return AgeCost(f=lambda a: a**k, integral=lambda a: a ** (k + 1) / (k + 1))


class Whittle:
    """The paper's index ``w p A^2``, generalised to a cost f (Tripathi and Modiano).

    For cost f the index is ``2 w p (A f(A) - F(A))``; for f(A) = A this is exactly
    ``w p A^2``, which is computed directly on the hot path.
    """

    name = "whittle"

    def __init__(self, cost: AgeCost = LINEAR_COST) -> None:
        self.cost = cost

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        if self.cost is LINEAR_COST:
            return int(np.argmax(w * p * h * h))
        return int(np.argmax(2.0 * w * p * (h * self.cost.f(h) - self.cost.integral(h))))


class WhittleExact:
    """Kadota et al.'s exact index for the slotted model: ``w p h (h + 2/p - 1) / 2``.

    Ages ``h`` are in slots (the leader passes age divided by its mean poll time).
    """

    name = "whittle-exact"

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        return int(np.argmax(w * p * h * (h + 2.0 / p - 1.0)))


class MaxWeight:
    """Kadota et al.'s Max-Weight: ``w p h (h + 2)``, the drift of a quadratic Lyapunov."""

    name = "max-weight"

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        return int(np.argmax(w * p * h * (h + 2.0)))


class MaxAge:
    """Greedy: the oldest information first, ignoring weights and reliabilities."""

    name = "max-age"

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        return int(np.argmax(h))


class RoundRobin:
    """Each follower in turn, in the order they are indexed."""

    name = "round-robin"

    def __init__(self) -> None:
        self._last = -1

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        self._last = (self._last + 1) % len(h)
        return self._last


class RandomChoice:
    """Uniformly at random, from the injected generator (for reproducible runs)."""

    name = "random"

    def __init__(self, rng: random.Random) -> None:
        self._rng = rng

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        return self._rng.randrange(len(h))


POLICIES: dict[str, Callable[[random.Random], Policy]] = {
    "whittle": lambda rng: Whittle(),
    "whittle-exact": lambda rng: WhittleExact(),
    "max-weight": lambda rng: MaxWeight(),
    "max-age": lambda rng: MaxAge(),
    "round-robin": lambda rng: RoundRobin(),
    "random": lambda rng: RandomChoice(rng),
}


def make_policy(name: str, rng: random.Random | None = None) -> Policy:
    """The policy registered under ``name``; ValueError lists the names that exist."""
    try:
        factory = POLICIES[name]
    except KeyError:
        raise ValueError(f"policy must be one of {sorted(POLICIES)}, got {name!r}") from None
    return factory(rng if rng is not None else random.Random(0))
