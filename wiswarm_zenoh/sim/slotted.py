"""The slotted channel of Kadota et al.: the theory reference for the policies.

One transmission per slot; the follower chosen by the (core's) policy delivers a fresh
update with probability p_i. Ages count slots: a delivered update has age 1 at the end
of its slot, every other age grows by one. The result is compared with the lower bound
L_B that no policy can beat.
"""

from __future__ import annotations

import math
import random
from dataclasses import asdict, dataclass

import numpy as np

from wiswarm_zenoh.core.policies import make_policy
from wiswarm_zenoh.sim.metrics import lower_bound

DEFAULT_WEIGHTS = (1.0, 5.0)
DEFAULT_RELIABILITY = (0.5, 1.0)
DEFAULT_SLOTS = 100_000


@dataclass(frozen=True)
class SlottedResult:
    """Weighted-sum AoI of one policy over one random network, against L_B."""

    n: int
    policy: str
    seed: int
    slots: int
    w: list[float]
    p: list[float]
    mean_aoi: list[float]
    ewsaoi: float
    lower_bound: float
    ratio: float

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


def check_range(name: str, lo: float, hi: float, low_open: float, high: float) -> None:
    """``low_open < lo <= hi <= high`` or ValueError naming the range."""
    if not (math.isfinite(lo) and math.isfinite(hi) and low_open < lo <= hi <= high):
        raise ValueError(f"{name} must satisfy {low_open:g} < LO <= HI <= {high:g}, got {lo}:{hi}")


@dataclass(frozen=True)
class SlottedSpec:
    """A slotted run: N followers with w ~ U[weights], p ~ U[reliability] drawn from seed."""

    n: int
    policy: str = "whittle"
    seed: int = 0
    weights: tuple[float, float] = DEFAULT_WEIGHTS
    reliability: tuple[float, float] = DEFAULT_RELIABILITY
    slots: int = DEFAULT_SLOTS

    def __post_init__(self) -> None:
        if self.n < 1:
            raise ValueError(f"n must be >= 1, got {self.n}")
        if self.slots < 1:
            raise ValueError(f"slots must be >= 1, got {self.slots}")
        check_range("weights", *self.weights, 0.0, math.inf)
        check_range("reliability", *self.reliability, 0.0, 1.0)
        make_policy(self.policy)


def run_slotted(spec: SlottedSpec) -> SlottedResult:
    """Run ``spec.slots`` slots of the core policy and compare with L_B."""
    rng = random.Random(spec.seed)
    w = [rng.uniform(*spec.weights) for _ in range(spec.n)]
    p = [rng.uniform(*spec.reliability) for _ in range(spec.n)]
    chooser = make_policy(spec.policy, random.Random(rng.getrandbits(64)))
    success = np.random.default_rng(rng.getrandbits(64)).random(spec.slots)
    w_arr, p_arr = np.array(w), np.array(p)
    ages = np.ones(spec.n)
    area = np.zeros(spec.n)
    choose = chooser.choose
    for k in range(spec.slots):
        i = choose(w_arr, p_arr, ages)
        ages += 1.0
        if success[k] < p[i]:
            ages[i] = 1.0
        area += ages
    mean_aoi = area / spec.slots
    ewsaoi = float(np.dot(w_arr, mean_aoi)) / spec.n
    bound = lower_bound(w, p)
    return SlottedResult(
        n=spec.n, policy=spec.policy, seed=spec.seed, slots=spec.slots, w=w, p=p,
        mean_aoi=mean_aoi.tolist(), ewsaoi=ewsaoi, lower_bound=bound, ratio=ewsaoi / bound,
    )
