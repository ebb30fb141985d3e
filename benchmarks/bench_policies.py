"""Decision time of each scheduling policy, and of a whole leader poll/reply cycle.

Prints two tables (medians in microseconds) for N = 14, 100, 1000, 10000 followers:
1. ``policy.choose(w, p, h)`` alone, on random arrays from a seeded generator;
2. ``Leader.next_poll`` + ``Leader.receive_reply`` and its events drained (one
   single-fragment delivery), i.e. the policy plus everything the leader does around
   it, with and without control information (one waypoint per follower, broadcast
   with every poll).
The issue's target: whittle under 50 microseconds per decision at N = 1000.
"""

from __future__ import annotations

import argparse
import random
import statistics
import time

import numpy as np

from wiswarm_zenoh.core import POLICIES, Follower, Leader, LeaderConfig, drain, make_policy

SIZES = (14, 100, 1000, 10000)
TARGET_US = 50.0


def policy_median_us(name: str, n: int, repeats: int, seed: int) -> float:
    """Median time of one decision, over ``repeats`` calls on 16 rotating random inputs."""
    gen = np.random.default_rng(seed)
    inputs = [(gen.uniform(0.1, 5.0, n), gen.uniform(0.05, 1.0, n), gen.uniform(0.0, 100.0, n))
              for _ in range(16)]
    policy = make_policy(name, random.Random(seed))
    for w, p, h in inputs:  # warm-up
        policy.choose(w, p, h)
    samples = []
    for k in range(repeats):
        w, p, h = inputs[k % len(inputs)]
        start = time.perf_counter()
        policy.choose(w, p, h)
        samples.append(time.perf_counter() - start)
    return 1e6 * statistics.median(samples)


def cycle_medians_us(n: int, repeats: int, seed: int, control: bool) -> tuple[float, float]:
    """Median times of ``next_poll`` and of ``receive_reply`` with its events drained (a
    delivered 1 kB update)."""
    rng = random.Random(seed)
    leader = Leader(LeaderConfig(policy="whittle"), rng)
    followers = {f"f{i}": Follower(f"f{i}") for i in range(n)}
    for i, fid in enumerate(followers):
        leader.add_follower(fid, 0.0)
        if control:
            leader.set_control(fid, [(1.0, float(i), 0.0, 10.0)])
    payload = bytes(1000)
    now = 1.0
    polls, replies = [], []
    for k in range(repeats + 20):  # the first 20 are warm-up
        now += 0.001
        start = time.perf_counter()
        request = leader.next_poll(now)
        polled = time.perf_counter()
        assert request is not None
        follower = followers[request.follower]
        follower.offer(payload, now - 0.0005)
        raw = follower.on_poll(request.payload, now + 0.0002, now + 0.0002)
        now += 0.0004
        answered = time.perf_counter()
        leader.receive_reply(request.follower, raw, now)
        drain(leader)
        done = time.perf_counter()
        if k >= 20:
            polls.append(polled - start)
            replies.append(done - answered)
    return 1e6 * statistics.median(polls), 1e6 * statistics.median(replies)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2000, help="decisions per cell")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    names = list(POLICIES)
    print("Policy decision time, median microseconds per choose(w, p, h)")
    print(f"{'policy':>14}" + "".join(f"{f'N={n}':>12}" for n in SIZES))
    whittle_1000 = 0.0
    for name in names:
        cells = [policy_median_us(name, n, args.repeats, args.seed) for n in SIZES]
        if name == "whittle":
            whittle_1000 = cells[SIZES.index(1000)]
        print(f"{name:>14}" + "".join(f"{c:12.2f}" for c in cells))

    print("\nLeader cycle (whittle), median microseconds per decision")
    print(f"{'N':>7}{'poll':>10}{'reply':>10}{'total':>10}"
          f"{'poll+ctl':>10}{'total+ctl':>10}")
    for n in SIZES:
        repeats = max(200, args.repeats // (1 if n < 10000 else 4))
        poll_us, reply_us = cycle_medians_us(n, repeats, args.seed, control=False)
        poll_c, reply_c = cycle_medians_us(n, repeats, args.seed, control=True)
        print(f"{n:>7}{poll_us:10.1f}{reply_us:10.1f}{poll_us + reply_us:10.1f}"
              f"{poll_c:10.1f}{poll_c + reply_c:10.1f}")

    verdict = "meets" if whittle_1000 < TARGET_US else "MISSES"
    print(f"\nwhittle at N=1000: {whittle_1000:.2f} us per decision, {verdict} the "
          f"{TARGET_US:.0f} us target")


if __name__ == "__main__":
    main()
