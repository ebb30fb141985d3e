"""The soak's plan: when each fault of ``bench_soak.py`` comes (churn, the hung follower,
the leader's kill, the samples), and the run's events in order."""

from __future__ import annotations

import dataclasses
import heapq
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Plan:
    """When each fault comes, in seconds from the start (the steady followers' first
    deliveries); the defaults are the issue's."""

    minutes: float = 25.0
    steady: int = 8
    churn_every: float = 10.0
    hang_every: float = 60.0
    hang_at: float = 20.0  # into each hang period
    hang_for: float = 3.0
    leader_kill_at: float = 0.6  # of the run: mid-way through the interval there
    sample_every: float = 30.0
    baseline: float = 300.0  # the steady followers' reference rate: the first 5 minutes
    shared_memory: bool = False

    @property
    def seconds(self) -> float:
        return self.minutes * 60.0

    @property
    def kill_time(self) -> float:
        """When the leader is killed: in the middle of an interval, so that the interval
        it falls in is plain, and no sample catches the new leader starting."""
        every = self.sample_every
        return math.floor(self.seconds * self.leader_kill_at / every) * every + every / 2

    def scaled(self, factor: float) -> Plan:
        """Every period (churn, hang, samples, the reference window) times ``factor``:
        the same run, quicker (tests/test_soak.py)."""
        return dataclasses.replace(
            self, churn_every=self.churn_every * factor, hang_every=self.hang_every * factor,
            hang_at=self.hang_at * factor, hang_for=self.hang_for * factor,
            sample_every=self.sample_every * factor, baseline=self.baseline * factor)


def schedule(plan: Plan) -> list[tuple[float, int, str]]:
    """(time, order, what) of every event of the run."""
    events: list[tuple[float, int, str]] = []
    n = int(plan.seconds // plan.churn_every)
    events += [(k * plan.churn_every, 2, f"churn {k}") for k in range(1, n + 1)
               if k * plan.churn_every < plan.seconds]
    m = int(plan.seconds // plan.hang_every) + 1
    for k in range(m):
        at = k * plan.hang_every + plan.hang_at
        if at + plan.hang_for < plan.seconds:
            events += [(at, 1, "hang"), (at + plan.hang_for, 1, "resume")]
    events.append((plan.kill_time, 0, "leader kill"))
    k = 1
    while k * plan.sample_every <= plan.seconds + 1e-9:
        # Half a second late: the leader's last batch of the interval has come in.
        events.append((k * plan.sample_every + 0.5, 3, "sample"))
        k += 1
    heapq.heapify(events)
    return events
