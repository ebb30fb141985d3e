"""The slotted model with sources of their own pace: the core's leader polls N followers
in slot time (a poll takes one slot, answered with probability p_i), and each follower's
source makes an update every ``interval_i`` slots, at a phase of its own: a poll finds
something new only if the source made one since the last update taken. The paper's
index assumes a fresh update always waits (every interval 1); here some sources are
slow. Compared: the paper's index (``pace_sources=False``) and the index on the age a
poll can remove (``sources``), by the weighted mean AoI of the fast followers and the
share of polls that found nothing new. While no source is due the paced leader sends no
poll: those slots stay idle (on a shared channel, free for anyone else)."""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

from wiswarm_zenoh.core import Delivered, Follower, Leader, LeaderConfig, drain


@dataclass(frozen=True)
class ArrivalSpec:
    """N followers with w ~ U[1, 5], p ~ U[``reliability``]; the first ``slow`` make an
    update every ``slow_interval`` slots, the others every slot."""

    n: int = 8
    slow: int = 4
    slow_interval: float = 20.0
    reliability: tuple[float, float] = (0.8, 1.0)
    paced: bool = True
    slots: int = 20_000
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0 <= self.slow < self.n:
            raise ValueError(f"slow must be in [0, n), got {self.slow}")
        if not self.slow_interval >= 1:
            raise ValueError(f"slow_interval must be >= 1 slot, got {self.slow_interval}")


@dataclass(frozen=True)
class ArrivalResult:
    fast_aoi: float  # weighted mean AoI of the fast followers, slots
    slow_aoi: float  # weighted mean AoI of the slow ones, slots
    empty_share: float  # polls that found nothing new, of all polls
    polls: int


def run_arrivals(spec: ArrivalSpec) -> ArrivalResult:
    rng = random.Random(spec.seed)
    names = [f"f{i}" for i in range(spec.n)]
    w = {f: rng.uniform(1.0, 5.0) for f in names}
    p = {f: rng.uniform(*spec.reliability) for f in names}
    interval = {f: spec.slow_interval if i < spec.slow else 1.0 for i, f in enumerate(names)}
    made = {f: -rng.random() * interval[f] for f in names}  # the last one made, its phase
    leader = Leader(LeaderConfig(timeout=1.0, adaptive_timeout=False, price_by_time=False,
                                 pace_sources=spec.paced), random.Random(rng.getrandbits(64)))
    followers = {f: Follower(f) for f in names}
    for f in names:
        leader.add_follower(f, 0.0)
        leader.observe_urgency(f, w[f])
    t, empty = 0.0, 0
    while t < spec.slots:
        request = leader.next_poll(t)
        if request is None:  # no source due: idle until the first is (whole slots)
            wake = leader.get_timer()
            assert wake is not None
            t = max(t + 1.0, math.ceil(wake))
            continue
        f = request.follower
        while made[f] + interval[f] <= t:
            made[f] += interval[f]
            followers[f].offer(b"x", made[f])
        if rng.random() < p[f]:
            reply = followers[f].on_poll(request.payload, t, t)
            leader.receive_reply(f, reply, t + 1.0)
            if not any(isinstance(e, Delivered) for e in drain(leader)):
                empty += 1
        else:
            leader.handle_timer(t + 1.0)
            drain(leader)
        t += 1.0

    def weighted(group: list[str]) -> float:
        return sum(w[f] * leader.stats(f, t).mean_aoi_s for f in group) / len(group)

    return ArrivalResult(fast_aoi=weighted(names[spec.slow:]),
                         slow_aoi=weighted(names[:spec.slow]) if spec.slow else 0.0,
                         empty_share=empty / max(leader.polls, 1), polls=leader.polls)
