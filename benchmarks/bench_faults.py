"""Faults on a swarm of real processes (loopback, every node a client of the router).

Each case starts ``wiswarm router``, ``wiswarm leader --record`` and ``wiswarm follower``
processes, as a user would, lets them settle, injects one fault and reads what the
others kept getting from the leader's record:

- stopped followers (SIGSTOP for ``--stop`` s, then SIGCONT): the others' delivery rate
  during the stop against their rate just before (target >= 0.80), N = 3 with one stopped
  and N = 14 with two;
- the router killed and started again after 1 s: how long after it listens again the
  deliveries resume (target <= 1.5 s), and whether the nodes said they lost it and got it
  back;
- a follower killed mid-update (8 kB fragments of 50 kB frames): the others' rate, and no
  update delivered twice;
- ``rogue``: with 3 followers (20 kB frames at 100 Hz), a member that never gives a
  valid answer joins (a token with no queryable, a hung queryable, one replying garbage;
  a churn of hung ones, a new name every second for 8 s): the others' delivery rate
  over the 6 s after it joins and over its first second, against the 3 s before
  (targets >= 0.95 and >= 0.80; churn >= 0.90);
- ``sim``: the slotted model with faults (``sim.faults``): the index per unit of expected
  poll time against the paper's, by the weighted mean AoI of the live followers, over K
  (slots a timeout costs) and the share of dead or intermittent followers (N = 14);
- ``wifi``: the same over the 802.11 model (49 kB frames, N = 14, dead followers' links
  deliver nothing), K set by the leader's timeout against the poll time it measures.

    .venv/bin/python benchmarks/bench_faults.py            # all cases, about 3 minutes
    .venv/bin/python benchmarks/bench_faults.py --stop 2 --cases stop
"""

from __future__ import annotations

import argparse
import dataclasses
import signal
import tempfile
import time
from collections import Counter
from pathlib import Path

from wiswarm_zenoh.sim.faults import FaultSpec, run_faults
from wiswarm_zenoh.sim.metrics import WifiResult
from wiswarm_zenoh.sim.scenario import WifiScenario, run_wifi
from wiswarm_zenoh.testbed.faults import FaultySwarm, first_after, rate
from wiswarm_zenoh.testbed.rogues import KINDS
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.keys import SwarmKeys

SETTLE = 3.0  # seconds of normal polling before a fault: the baseline window


def stopped(n: int, stop_count: int, seconds: float) -> None:
    names = [f"f{i}" for i in range(n)]
    victims, others = names[:stop_count], names[stop_count:]
    with tempfile.TemporaryDirectory() as tmp, FaultySwarm(Path(tmp), names) as swarm:
        swarm.wait_deliveries(names, 20)
        time.sleep(SETTLE)  # the baseline window
        start = time.time()
        for victim in victims:
            swarm.followers[victim].signal(signal.SIGSTOP)
        time.sleep(seconds)
        end = time.time()
        for victim in victims:
            swarm.followers[victim].signal(signal.SIGCONT)
        swarm.wait_deliveries(victims, 1, after=end, timeout=30.0)
        back = first_after([d for d in swarm.deliveries() if d.follower in victims], end)
        done = swarm.deliveries()
        before = rate(done, others, start - SETTLE, start)
        during = rate(done, others, start, end)
        assert swarm.leader is not None
        said = [text for text in ("stopped answering", "answers again")
                if swarm.leader.said(text)]
    print(f"N = {n}, {stop_count} stopped for {seconds:g} s: the other {len(others)} "
          f"deliver {during:.0f}/s during the stop against {before:.0f}/s before: "
          f"{during / before:.2f} (target >= 0.80); the stopped ones delivered again "
          f"{(back or end) - end:.2f} s after SIGCONT; the leader said: {said}")


def router_restart() -> None:
    names = ["f0", "f1", "f2"]
    with tempfile.TemporaryDirectory() as tmp, FaultySwarm(Path(tmp), names) as swarm:
        swarm.wait_deliveries(names, 20)
        killed = swarm.kill_router()
        time.sleep(1.0)
        back = swarm.start_router()
        swarm.wait_deliveries(names, 1, after=back, timeout=30.0)
        time.sleep(1.0)
        done = swarm.deliveries()
        resumed = first_after(done, back)
        gap = max(d.delivered_at for d in done if d.delivered_at < killed + 0.5)
        assert swarm.leader is not None
        lost = [p.name for p in (swarm.leader, *swarm.followers.values())
                if p.said("lost its router")]
        regained = [p.name for p in (swarm.leader, *swarm.followers.values())
                    if p.said("router reached again")]
    print(f"router killed, restarted 1 s later: deliveries resumed "
          f"{(resumed or back) - back:.2f} s after it listened again (target <= 1.5 s; "
          f"last delivery before: {killed - gap:+.2f} s from the kill); said it lost the "
          f"router: {lost}; said it was back: {regained}")


def killed_mid_update() -> None:
    names = ["f0", "f1", "f2"]
    with tempfile.TemporaryDirectory() as tmp, \
            FaultySwarm(Path(tmp), names, fragment_size=8192) as swarm:
        swarm.wait_deliveries(names, 20)
        time.sleep(SETTLE)
        killed = time.time()
        swarm.followers["f2"].signal(signal.SIGKILL)
        time.sleep(SETTLE)
        done = swarm.deliveries()
        before = rate(done, ["f0", "f1"], killed - SETTLE, killed)
        after = rate(done, ["f0", "f1"], killed, killed + SETTLE)
        twice = [key for key, count in Counter((d.follower, d.update_seq) for d in done).items()
                 if count > 1]
        assert swarm.leader is not None
        left = swarm.leader.said("follower f2 left")
    print(f"a follower killed mid-update (8 kB fragments): the others deliver {after:.0f}/s "
          f"after against {before:.0f}/s before: {after / before:.2f}; delivered twice: "
          f"{twice or 'none'}; the leader said f2 left: {left}")


def rogues() -> None:
    names = ["f0", "f1", "f2"]
    print("\na member that never answers joins 3 followers (20 kB frames, 100 Hz): the "
          "others' delivery rate, against the 3 s before")
    for kind, rogue in KINDS.items():
        window = 8.0 if kind == "churn" else 6.0
        with tempfile.TemporaryDirectory() as tmp, \
                FaultySwarm(Path(tmp), names, frame_bytes=20_000) as swarm, \
                SessionSpec.loopback("client", connect_ports=[swarm.port]).open() as session:
            swarm.wait_deliveries(names, 20)
            time.sleep(SETTLE)  # the baseline window
            joined = time.time()
            with rogue(session, SwarmKeys("swarm")):
                time.sleep(window)
            done = swarm.deliveries()
        before = rate(done, names, joined - SETTLE, joined)
        first = rate(done, names, joined, joined + 1.0)
        after = rate(done, names, joined, joined + window)
        target = "0.90" if kind == "churn" else "0.95; first second >= 0.80"
        print(f"  {kind:15s}: {after:5.0f}/s over {window:g} s ({after / before:.2f}), "
              f"{first:5.0f}/s in the first second ({first / before:.2f}), against "
              f"{before:.0f}/s before (targets >= {target})")


def simulated(seeds: int, slots: int) -> None:
    print(f"\nslotted model with faults, N = 14, {seeds} seeds x {slots} slots: weighted mean "
          "AoI of the live followers (slots), paper's index -> priced index (ratio)")
    cases = [(0, 0), (1, 0), (3, 0), (7, 0), (0, 1), (0, 3)]
    print("   K  " + "".join(f"{f'{d} dead, {i} flaky':>24}" for d, i in cases))
    for k in (1.0, 10.0, 100.0):
        cells = []
        for dead, flaky in cases:
            paper = priced = 0.0
            for seed in range(seeds):
                spec = FaultSpec(dead=dead, intermittent=flaky, timeout_slots=k, seed=seed,
                                 slots=slots, priced=False)
                paper += run_faults(spec) / seeds
                priced += run_faults(dataclasses.replace(spec, priced=True)) / seeds
            cells.append(f"{paper:7.1f} -> {priced:7.1f} ({priced / paper:4.2f})")
        print(f"{k:4.0f}  " + "".join(f"{cell:>24}" for cell in cells))


def wifi(seeds: int, duration: float) -> None:
    print(f"\n802.11 model with dead followers, N = 14, {seeds} seeds x {duration:g} s: mean "
          "AoI of the live followers (ms), paper's index -> priced index (ratio)")
    deads = (0, 1, 3)
    print("  timeout " + "".join(f"{f'{d} dead':>26}" for d in deads))
    for timeout in (0.05, 0.3, 1.0):
        cells = []
        for dead in deads:
            paper = priced = 0.0
            for seed in range(seeds):
                s = WifiScenario(n=14, duration=duration, seed=seed, dead=dead,
                                 timeout=timeout, price_by_time=False)
                paper += live_mean_aoi(run_wifi(s), dead) / seeds
                priced += live_mean_aoi(run_wifi(dataclasses.replace(
                    s, price_by_time=True)), dead) / seeds
            cells.append(f"{paper * 1e3:7.0f} -> {priced * 1e3:7.0f} ({priced / paper:4.2f})")
        print(f"  {timeout * 1e3:5.0f} ms" + "".join(f"{cell:>26}" for cell in cells))


def live_mean_aoi(result: WifiResult, dead: int) -> float:
    live = result.followers[dead:]
    return sum(f.mean_aoi_s for f in live) / len(live)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stop", type=float, default=5.0, help="seconds a follower is stopped")
    cases = ["stop", "router", "kill", "rogue", "sim", "wifi"]
    parser.add_argument("--cases", nargs="+", default=cases, choices=cases)
    parser.add_argument("--seeds", type=int, default=10, help="sim: runs per cell")
    parser.add_argument("--slots", type=int, default=50_000, help="sim: slots per run")
    parser.add_argument("--wifi-seconds", type=float, default=20.0,
                        help="wifi: simulated seconds per run")
    args = parser.parse_args()
    if "stop" in args.cases:
        stopped(3, 1, args.stop)
        stopped(14, 2, args.stop)
    if "router" in args.cases:
        router_restart()
    if "kill" in args.cases:
        killed_mid_update()
    if "rogue" in args.cases:
        rogues()
    if "sim" in args.cases:
        simulated(args.seeds, args.slots)
    if "wifi" in args.cases:
        wifi(3, args.wifi_seconds)


if __name__ == "__main__":
    main()
