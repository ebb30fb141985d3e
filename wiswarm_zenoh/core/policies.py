"""Scheduling policies: who to poll next, given weights w, reliabilities p and ages h.

Every policy decides in two equivalent ways: ``choose`` on numpy arrays in one
vectorised pass (many followers), and ``choose_in_lists`` on plain float sequences (a
swarm of a few dozen: there numpy's fixed cost per call dominates, more so when the
leader wakes up cold for every poll). Both break ties deterministically (lowest index,
i.e. the follower that joined first), except ``random``, whose randomness comes from
the injected generator.
"""

from __future__ import annotations

import math
import random
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
CostFn = Callable[[Any], Any]  # on a float or an array of ages alike
Floats = Sequence[float]
X = TypeVar("X", float, FloatArray)


class Policy(Protocol):
    """Picks the index of the follower to poll; inputs have one entry per follower."""

    name: str

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        """The position of the follower to poll, from weights, reliabilities and ages."""

    def choose_in_lists(self, w: Floats, p: Floats, h: Floats) -> int:
        """As ``choose``, from plain lists (faster than arrays for small swarms)."""


class IndexPolicy(ABC):
    """Polls the follower with the largest index ``index(w, p, h)``, written once for
    floats and arrays alike (numpy's operators on arrays, Python's on floats, in the
    same order: both ways give the same pick)."""

    name = ""

    @abstractmethod
    def index(self, w: X, p: X, h: X) -> X:
        """The index of each follower (larger: poll sooner)."""

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        # the method, not np.argmax: its wrapper costs more than the pass at N = 1000
        return int(self.index(w, p, h).argmax())

    def indices(self, w: Floats, p: Floats, h: Floats) -> list[float]:
        """The index of each follower, on plain floats."""
        return list(map(self.index, w, p, h))

    def choose_in_lists(self, w: Floats, p: Floats, h: Floats) -> int:
        values = self.indices(w, p, h)
        return values.index(max(values))  # the first of equals, as np.argmax

    def age_below(self, value: float, w: float, p: float) -> float | None:
        """An age (in slots) up to which a follower of ``w`` and ``p`` surely has an index
        below ``value`` (a little under the exact bound: rounding cannot cross it), or
        None where this policy cannot say without computing the index."""
        return None


@dataclass(frozen=True)
class AgeCost:
    """A non-decreasing cost f(A) of age and its integral F(A) = int_0^A f (F(0) = 0)."""

    f: CostFn
    integral: CostFn


LINEAR_COST = AgeCost(f=lambda a: a, integral=lambda a: 0.5 * a * a)


def power_cost(k: float) -> AgeCost:
    """f(A) = A^k, for k > 0."""
    if not k > 0:
        raise ValueError(f"power cost exponent must be > 0, got {k}")
    return AgeCost(f=lambda a: a**k, integral=lambda a: a ** (k + 1) / (k + 1))


class Whittle(IndexPolicy):
    """The paper's index ``w p A^2``, generalised to a cost f (Tripathi and Modiano).

    For cost f the index is ``2 w p (A f(A) - F(A))``; for f(A) = A this is exactly
    ``w p A^2``, which is computed directly on the hot path.
    """

    name = "whittle"

    def __init__(self, cost: AgeCost = LINEAR_COST) -> None:
        self.cost = cost

    def index(self, w: X, p: X, h: X) -> X:
        cost = self.cost
        if cost is LINEAR_COST:
            return w * p * h * h
        general: X = 2.0 * w * p * (h * cost.f(h) - cost.integral(h))
        return general

    def indices(self, w: Floats, p: Floats, h: Floats) -> list[float]:
        if self.cost is not LINEAR_COST:
            return super().indices(w, p, h)
        # The paper's index in one comprehension: no call per follower on every poll.
        return [wi * pi * hi * hi for wi, pi, hi in zip(w, p, h, strict=True)]

    def age_below(self, value: float, w: float, p: float) -> float | None:
        if self.cost is not LINEAR_COST or not value > 0.0:
            return None
        if not w * p > 0.0:
            return math.inf  # an index of 0 at any age
        return math.sqrt(value / (w * p)) * (1.0 - 1e-9)  # w p h^2 < value


class WhittleExact(IndexPolicy):
    """Kadota et al.'s exact index for the slotted model, ``w p h (h + 2/p - 1) / 2``,
    computed without the ``/ 2``: a common factor changes no choice.

    Ages ``h`` are in slots (the leader passes age divided by its mean poll time).
    """

    name = "whittle-exact"

    def index(self, w: X, p: X, h: X) -> X:
        return w * p * h * (h + 2.0 / p - 1.0)


class MaxWeight(IndexPolicy):
    """Kadota et al.'s Max-Weight: ``w p h (h + 2)``, the drift of a quadratic Lyapunov."""

    name = "max-weight"

    def index(self, w: X, p: X, h: X) -> X:
        return w * p * h * (h + 2.0)


class MaxAge(IndexPolicy):
    """Greedy: the oldest information first, ignoring weights and reliabilities."""

    name = "max-age"

    def index(self, w: X, p: X, h: X) -> X:
        return h


class RoundRobin:
    """Each follower in turn, in the order they are indexed."""

    name = "round-robin"

    def __init__(self) -> None:
        self._last = -1

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        return self.choose_in_lists(w, p, h)  # type: ignore[arg-type]

    def choose_in_lists(self, w: Floats, p: Floats, h: Floats) -> int:
        self._last = (self._last + 1) % len(h)
        return self._last


class RandomChoice:
    """Uniformly at random, from the injected generator (for reproducible runs)."""

    name = "random"

    def __init__(self, rng: random.Random) -> None:
        self._rng = rng

    def choose(self, w: FloatArray, p: FloatArray, h: FloatArray) -> int:
        return self._rng.randrange(len(h))

    def choose_in_lists(self, w: Floats, p: Floats, h: Floats) -> int:
        return self._rng.randrange(len(h))


POLICIES: dict[str, Callable[[random.Random], Policy]] = {
    "whittle": lambda rng: Whittle(),
    "whittle-exact": lambda rng: WhittleExact(),
    "max-weight": lambda rng: MaxWeight(),
    "max-age": lambda rng: MaxAge(),
    "round-robin": lambda rng: RoundRobin(),
    "random": lambda rng: RandomChoice(rng),
}
"""Every policy by name (``LeaderConfig.policy``), each made from a ``random.Random``."""


def make_policy(name: str, rng: random.Random | None = None) -> Policy:
    """The policy registered under ``name``; ValueError lists the names that exist."""
    try:
        factory = POLICIES[name]
    except KeyError:
        raise ValueError(f"policy must be one of {sorted(POLICIES)}, got {name!r}") from None
    return factory(rng if rng is not None else random.Random(0))
