"""Polls per second with Zenoh's shared memory on against off, on one host.

Zenoh moves payloads of 3 kB or more between sessions on one host through shared memory
unless ``transport/shared_memory/enabled`` is false; this project turns it off unless a
node is given ``--shared-memory`` (docs/guides/swarm.md#shared-memory). This measures
what that costs polling where it could help most: every process on one host, 50 kB
updates, a fresh one each poll. Two swarms run side by side, one with shared memory on
every node (router, followers, leader) and one with it off on every node, each a router
and N followers (a process per follower by default, as deployed); the leader's rounds
(bench_poll's ``leader_round``) alternate between them so that the machine's drift
cancels. Printed: each swarm's median polls/s and mean AoI, the median of the paired
ratios on / off with its quartiles, and the shared-memory segments the leader's process
mapped (so that "on" is seen to use it).

    .venv/bin/python benchmarks/bench_shm.py                    # N = 4, peers and clients
    .venv/bin/python benchmarks/bench_shm.py -n 14 --modes client --layout host
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import statistics
from pathlib import Path

from bench_poll import Job, children, followers_process, leader_round

from wiswarm_zenoh.core import LeaderConfig
from wiswarm_zenoh.programs.runners import run_router
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

SETTINGS = ("on", "off")


def zenoh_segments(pid: int | str = "self") -> set[str]:
    """The Zenoh shared-memory files a process maps (``/dev/shm/<id>.zenoh``, unlinked
    ones too); none for a process that has ended."""
    try:
        with open(f"/proc/{pid}/maps") as maps:
            return {word for line in maps for word in line.split() if word.endswith(".zenoh")}
    except OSError:
        return set()


def swarm(mode: str, shared_memory: bool, followers: list[str],
          args: argparse.Namespace) -> tuple[list[Job], SessionSpec]:
    """One swarm's processes (its router, its followers) and its leader's session spec."""
    port = free_tcp_port()
    router = dataclasses.replace(SessionSpec.loopback("router", port),
                                 shared_memory=shared_memory)
    node = dataclasses.replace(SessionSpec.loopback(mode, connect_ports=[port]),
                               shared_memory=shared_memory)
    hosts = [followers] if args.layout == "host" else [[f] for f in followers]
    return [(run_router, (router,)),
            *((followers_process, ([node] * len(names), names, args.frame_bytes, None, False))
              for names in hosts)], node


def measure(mode: str, args: argparse.Namespace) -> None:
    followers = [f"uav{i}" for i in range(args.followers)]
    config = LeaderConfig(policy="whittle", timeout=0.3)
    rates: dict[str, list[float]] = {s: [] for s in SETTINGS}
    means: dict[str, list[float]] = {s: [] for s in SETTINGS}
    jobs, leaders = [], {}
    for setting in SETTINGS:
        setting_jobs, leaders[setting] = swarm(mode, setting == "on", followers, args)
        jobs += setting_jobs
    with children(jobs), contextlib.ExitStack() as stack:
        sessions = {s: stack.enter_context(leaders[s].open()) for s in SETTINGS}
        for i in range(args.rounds):
            for setting in SETTINGS if i % 2 == 0 else SETTINGS[::-1]:
                rate, stats, _ = leader_round(sessions[setting], args.followers,
                                              args.seconds, config)
                rates[setting].append(rate)
                means[setting].append(statistics.mean(float(r["mean_aoi_s"]) for r in stats))
        mapped = zenoh_segments()
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"\nN = {args.followers}, {args.frame_bytes} B updates (a fresh one each poll), "
          f"{mode}s of a router, followers in "
          f"{'one host process' if args.layout == 'host' else 'a process each'}, "
          f"{args.rounds} rounds of {args.seconds:g} s per swarm, alternating "
          f"(load average {load} on {os.cpu_count()} CPUs)")
    for setting in SETTINGS:
        print(f"  shared memory {setting:3}  {statistics.median(rates[setting]):8.0f} polls/s"
              f"   mean AoI {statistics.median(means[setting]) * 1e3:6.2f} ms   (rounds: "
              f"{', '.join(f'{x:.0f}' for x in rates[setting])})")
    paired = sorted(a / b for a, b in zip(rates["on"], rates["off"], strict=True))
    low, median, high = statistics.quantiles(paired, n=4) if len(paired) > 1 else paired * 3
    print(f"  on / off            {median:8.2f}   (median of {len(paired)} paired rounds, "
          f"quartiles {low:.2f} .. {high:.2f})")
    print(f"  segments the leader's process maps: {len(mapped)} "
          f"({sum(Path(m).stat().st_size for m in mapped if Path(m).exists()) / 2**20:.1f}"
          " MiB)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", "--followers", type=int, default=4)
    parser.add_argument("--frame-bytes", type=int, default=50176)
    parser.add_argument("--seconds", type=float, default=1.5, help="length of each round")
    parser.add_argument("--rounds", type=int, default=8, help="rounds per swarm")
    parser.add_argument("--modes", nargs="+", choices=["peer", "client"],
                        default=["peer", "client"])
    parser.add_argument("--layout", choices=["host", "processes"], default="processes",
                        help="the followers' sessions in one host process, or a process "
                        "each (default, as deployed)")
    args = parser.parse_args()
    for mode in args.modes:
        measure(mode, args)


if __name__ == "__main__":
    main()
