"""The slotted model with faults: the core's own leader, where a lost poll costs K slots.

Kadota et al.'s model charges every poll one slot, answered or not. On a real network a
poll that goes unanswered holds the channel for the whole timeout, K slots. Here the
core ``Leader`` (its estimates of p, its probing of silent followers) polls N followers
in slot time: an answer takes 1 slot, a timeout K. Some followers are dead (they answer
their first poll, then never again: a member that never answered at all is silent from
its first miss and costs one poll whatever the index), some intermittent (down for
``outage`` slots out of every ``period``), the rest answer with probability p_i.
Compared: the paper's index (``price_by_time`` off) and the index per unit of expected
poll time (on), by the weighted mean AoI of the followers that are alive.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

from wiswarm_zenoh.core import Follower, Leader, LeaderConfig, drain

PROBE_INTERVAL = 100.0  # slots before a silent follower's first probe (doubling after)
PROBE_MAX = 1600.0


@dataclass(frozen=True)
class FaultSpec:
    """N followers, ``dead`` of them never answering and ``intermittent`` of them down
    ``outage`` slots in every ``period``; a timeout costs ``timeout_slots`` slots."""

    n: int = 14
    dead: int = 1
    intermittent: int = 0
    timeout_slots: float = 10.0
    priced: bool = True
    slots: int = 20_000
    seed: int = 0
    outage: int = 500
    period: int = 2_000

    def __post_init__(self) -> None:
        if not 0 <= self.dead + self.intermittent < self.n:
            raise ValueError("dead + intermittent must leave at least one follower alive")
        if not self.timeout_slots >= 1:
            raise ValueError(f"timeout_slots must be >= 1, got {self.timeout_slots}")


def run_faults(spec: FaultSpec) -> float:
    """The weighted mean AoI (slots) of the followers that answer at all."""
    rng = random.Random(spec.seed)
    names = [f"f{i}" for i in range(spec.n)]
    w = {f: rng.uniform(1.0, 5.0) for f in names}
    p = {f: rng.uniform(0.5, 1.0) for f in names}
    dead = set(names[:spec.dead])
    flaky = set(names[spec.dead:spec.dead + spec.intermittent])
    phase = {f: rng.randrange(spec.period) for f in flaky}
    config = LeaderConfig(timeout=spec.timeout_slots, adaptive_timeout=False,
                          price_by_time=spec.priced, probe_interval=PROBE_INTERVAL,
                          probe_max=PROBE_MAX)
    leader = Leader(config, random.Random(rng.getrandbits(64)))
    followers = {f: Follower(f) for f in names}
    for f in names:
        leader.add_follower(f, 0.0)
        leader.observe_urgency(f, w[f])  # the weight, through the EMA as in a real run
    t = 0.0
    request = leader.next_poll(t)
    died: set[str] = set()
    while t < spec.slots:
        assert request is not None
        f = request.follower
        down = f in died or (f in flaky and (t + phase[f]) % spec.period < spec.outage)
        first_of_dead = f in dead and f not in died
        if first_of_dead:
            died.add(f)
        if not down and (first_of_dead or rng.random() < p[f]):
            follower = followers[f]
            follower.offer(b"x", t)
            leader.receive_reply(f, follower.on_poll(request.payload, t, t), t + 1.0)
            t += 1.0
        else:
            t += spec.timeout_slots
            leader.handle_timer(t)
        request = leader.next_poll(t)
        drain(leader)
    alive = [f for f in names if f not in dead]
    weights = [leader.stats(f, t).weight for f in alive]
    return sum(wt * leader.stats(f, t).mean_aoi_s for wt, f in zip(weights, alive,
                                                                      strict=True)) / len(alive)
