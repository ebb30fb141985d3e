"""Soak: a swarm run as an operator runs one, for half an hour, with followers coming
and going, a hung follower and a leader restart; does anything grow, does anyone dip?

Every node is ``wiswarm router|leader|follower`` with the command line's defaults (50 kB
frames at 100 Hz, shared memory off unless ``--shared-memory``), each a client of the
router on loopback, each its own ``spawn`` process. Over ``--minutes``:

- ``--steady`` followers (8) run throughout;
- a new follower joins every 10 s and the one before it is killed, SIGKILL and SIGTERM
  in turn;
- one steady follower is stopped (SIGSTOP) for 3 s every minute;
- the leader is killed (SIGKILL) once, at 60 % of the run, and started again at once.

Every 30 s: resident memory (and the shared part), open fds and threads of the router
and the leader, the largest of the steady followers'; each steady follower's delivery
rate (from the leader's ``leader/deliveries`` stream, watched from this process) against
its rate over the first 5 minutes, and its largest gap between deliveries. At the end:
the table, the targets (router and leader memory at most +15 % from the 5-minute sample
to the end, fds and threads flat; every steady follower at least 80 % of its rate in
every interval but the leader kill's; nothing left in /dev/shm of what these processes
mapped), and a plot (PNG), the samples (CSV) and a summary (JSON) in ``--out``.

    .venv/bin/python benchmarks/bench_soak.py                 # 25 minutes
    .venv/bin/python benchmarks/bench_soak.py --minutes 3     # a quick look
    .venv/bin/python benchmarks/bench_soak.py --shared-memory # as before the decision
    .venv/bin/python benchmarks/bench_soak.py --minutes 0.4 --steady 2 --time-scale 0.2
"""

from __future__ import annotations

import argparse
import heapq
import math
import os
import signal
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from soak_plan import Plan, schedule
from soak_report import MIB, Sample, report
from soak_swarm import SWARM, Swarm, sample, wait_for_port

from wiswarm_zenoh import DeliveryRecord, LeaderSummary, Observer
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

READY_TIMEOUT = 60.0  # seconds; a loaded 2-core machine starts ten interpreters slowly


@dataclass
class Deliveries:
    """Each steady follower's deliveries per interval from ``begin``, and the largest gap
    ending in it (the leader's clock, which is this host's ``time.time``)."""

    every: float
    followers: tuple[str, ...]
    start: float = math.inf
    counts: dict[str, dict[int, int]] = field(default_factory=dict)
    gaps: dict[str, dict[int, float]] = field(default_factory=dict)
    last: dict[str, float] = field(default_factory=dict)
    mark: float = math.inf
    first_after: dict[str, float] = field(default_factory=dict)
    leader_seen: threading.Event = field(default_factory=threading.Event)
    cond: threading.Condition = field(default_factory=threading.Condition)

    def __call__(self, observation: object) -> None:
        if isinstance(observation, LeaderSummary):
            self.leader_seen.set()
        if not isinstance(observation, DeliveryRecord) or observation.outcome != "delivered" \
                or observation.follower not in self.followers:
            return
        at, who = observation.delivered_at, observation.follower
        with self.cond:
            if at >= self.start:
                k = math.floor((at - self.start) / self.every)
                counts = self.counts.setdefault(who, {})
                counts[k] = counts.get(k, 0) + 1
                if who in self.last:
                    gaps = self.gaps.setdefault(who, {})
                    gaps[k] = max(gaps.get(k, 0.0), at - self.last[who])
            self.last[who] = max(self.last.get(who, at), at)
            if at >= self.mark and who not in self.first_after:
                self.first_after[who] = at
                self.cond.notify_all()

    def begin(self) -> float:
        """Count from now on; the time."""
        with self.cond:
            self.start = time.time()
            return self.start

    def mark_now(self) -> float:
        """From now on, note each follower's first delivery (``first_after``)."""
        with self.cond:
            self.mark = time.time()
            self.first_after = {}
            return self.mark

    def wait_for_all(self, timeout: float) -> None:
        """Until every follower has delivered since ``mark_now``."""
        with self.cond:
            if not self.cond.wait_for(
                    lambda: len(self.first_after) == len(self.followers), timeout):
                raise RuntimeError(f"only {sorted(self.first_after)} delivered")


def run(plan: Plan, out: Path) -> dict[str, Any]:
    """The soak; its summary (also written to ``out``)."""
    out.mkdir(parents=True, exist_ok=True)
    port = free_tcp_port()
    swarm = Swarm(port, out, plan.shared_memory)
    steady = [f"steady{i}" for i in range(plan.steady)]
    hung = steady[-1]
    observer_spec = SessionSpec(mode="client", connect=(swarm.endpoint,),
                                multicast_scouting=False)
    samples: list[Sample] = []
    resumed: dict[str, float] = {}
    try:
        swarm.start("router", ["router"])
        wait_for_port(port, READY_TIMEOUT)
        deliveries = Deliveries(plan.sample_every, tuple(steady))
        with observer_spec.open() as session, Observer(session, SWARM, deliveries):
            swarm.start("leader", ["leader"])
            for name in steady:
                swarm.start(name, ["follower", "--id", name])
            if not deliveries.leader_seen.wait(READY_TIMEOUT):
                raise RuntimeError("the leader did not come up")
            deliveries.mark_now()
            deliveries.wait_for_all(READY_TIMEOUT)
            start = deliveries.begin()
            samples, resumed = _soak(plan, swarm, deliveries, steady, hung, start)
    finally:
        swarm.stop_all()
    counts, gaps = deliveries.counts, deliveries.gaps
    summary = report(plan, samples, counts, gaps, steady, resumed, swarm, out)
    return summary


def _soak(plan: Plan, swarm: Swarm, deliveries: Deliveries, steady: list[str], hung: str,
          start: float) -> tuple[list[Sample], dict[str, float]]:
    events = schedule(plan)
    leader, churned, kills = "leader", None, 0
    samples: list[Sample] = []
    happened: list[tuple[float, str]] = []  # since the last sample
    resumed: dict[str, float] = {}
    killed_at = math.nan
    while events:
        at, _, what = heapq.heappop(events)
        time.sleep(max(0.0, start + at - time.time()))
        if what.startswith("churn"):
            name = f"churn{what.split()[1]}"
            swarm.start(name, ["follower", "--id", name])
            if churned is not None:
                swarm.end(churned, signal.SIGKILL if kills % 2 == 0 else signal.SIGTERM)
                kills += 1
            churned = name
            swarm.reap()
        elif what == "hang":
            os.kill(swarm.pid(hung), signal.SIGSTOP)
            happened.append((at, "hang"))
        elif what == "resume":
            os.kill(swarm.pid(hung), signal.SIGCONT)
        elif what == "leader kill":
            killed_at = deliveries.mark_now()
            swarm.end(leader, signal.SIGKILL)
            leader = "leader2"
            swarm.start(leader, ["leader"])
            happened.append((at, "leader kill"))
        else:
            with deliveries.cond:  # every steady follower delivered again: how soon
                if not math.isnan(killed_at) and not resumed \
                        and len(deliveries.first_after) == len(steady):
                    resumed = {who: t - killed_at for who, t in deliveries.first_after.items()}
            swarm.note_segments()
            t = at - 0.5
            here = [what for when, what in happened if when < t]  # this interval's
            happened = [(when, what) for when, what in happened if when >= t]
            samples.append(Sample(t, sample(swarm, leader, steady), leader, here))
            print_row(samples[-1], deliveries, steady, round(t / plan.sample_every) - 1)
    return samples, resumed


def print_row(s: Sample, deliveries: Deliveries, steady: list[str], k: int) -> None:
    with deliveries.cond:
        rates = [deliveries.counts.get(who, {}).get(k, 0) for who in steady]
        gap = max(deliveries.gaps.get(who, {}).get(k, 0.0) for who in steady)
    r, ld = s.nodes["router"], s.nodes["leader"]
    print(f"{s.t / 60:5.1f} min  router {r['VmRSS'] / MIB:6.0f} MiB {r['fds']:4d} fds "
          f"{r['Threads']:3d} thr   {s.leader:7} {ld['VmRSS'] / MIB:6.0f} MiB {ld['fds']:4d} fds "
          f"{ld['Threads']:3d} thr   deliveries {min(rates)}..{max(rates)}  largest gap "
          f"{gap:5.2f} s  {', '.join(s.events)}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=Plan.minutes)
    parser.add_argument("--steady", type=int, default=Plan.steady)
    parser.add_argument("--shared-memory", action="store_true",
                        help="every node with Zenoh's shared memory on (as before the decision)")
    parser.add_argument("--time-scale", type=float, default=1.0, metavar="FACTOR",
                        help="every period (churn, hang, samples) times FACTOR")
    parser.add_argument("--out", type=Path,
                        default=Path("runs") / time.strftime("soak-%Y%m%d-%H%M%S"))
    args = parser.parse_args()
    plan = Plan(minutes=args.minutes, steady=args.steady, shared_memory=args.shared_memory)
    run(plan.scaled(args.time_scale), args.out)


if __name__ == "__main__":
    main()
