"""A follower as light as the paper's UAV computer needs: ``wiswarm follower``'s memory
and its CPU per answered poll.

A router and one ``wiswarm follower`` process (synthetic frames, the defaults: 50 kB at
100 Hz) come up on loopback, shared memory off; a ``LeaderNode`` in this process polls
it. Printed: the follower's resident memory 10 s after its start (target: at most 80 MB)
and at the end, the CPU time of its process over the polling window per poll it
answered, and which heavy libraries it loaded (none of the tracking app's, the
dashboard's or ROS 2's should be).

With ``--streams``, instead: a robot's four topics (50 kB samples at 30 Hz on four
keys, from another process) served by one ``wiswarm follower`` given ``--source`` four
times, against one follower serving one of them and four followers serving one each
(issue 42's target: one process of four streams at most 1.3x the memory of one of one
stream), all polled by one leader; resident memory of each after ``--seconds``.

    .venv/bin/python benchmarks/bench_follower.py
    .venv/bin/python benchmarks/bench_follower.py --seconds 20
    .venv/bin/python benchmarks/bench_follower.py --streams
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import threading
import time

from bench_poll import NO_SHM

from wiswarm_zenoh.core import LeaderConfig
from wiswarm_zenoh.transport import LeaderNode
from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port

HEAVY = ("cv2", "matplotlib", "aiohttp", "rosbags", "foxglove", "cryptography", "pymavlink")
SWARM = "benchfollower"


def rss_kb(pid: int) -> int:
    with open(f"/proc/{pid}/status") as status:
        return int(next(line for line in status if line.startswith("VmRSS:")).split()[1])


def cpu_s(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def loaded(pid: int) -> list[str]:
    """The heavy libraries mapped into the process (their shared objects)."""
    with open(f"/proc/{pid}/maps") as maps:
        text = maps.read()
    return [name for name in HEAVY if f"/{name}/" in text or f"/{name}." in text]


TOPICS = 4


def publisher(endpoint: str, stop: threading.Event) -> None:
    """The robot's topics: a 50 kB sample on each of TOPICS keys at 30 Hz."""
    spec = dataclasses.replace(SessionSpec(mode="client", connect=(endpoint,),
                                           multicast_scouting=False), cfg=NO_SHM)
    payload = bytes(50_000)
    with spec.open() as session:
        while not stop.wait(1 / 30):
            for k in range(TOPICS):
                session.put(f"robot/topic{k}", payload)


def streams(seconds: float) -> None:
    """One process of TOPICS streams, against one of one and TOPICS of one each."""
    port = free_tcp_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    wiswarm = os.path.join(os.path.dirname(sys.executable), "wiswarm")
    shm_off = ["--cfg", "transport/shared_memory/enabled:false", "--no-multicast-scouting"]
    sources = [["--source", f"robot/topic{k}"] for k in range(TOPICS)]
    every = [flag for pair in sources for flag in pair]
    layouts = {"one process, one stream": [("solo", sources[0])],
               f"one process, {TOPICS} streams": [("multi", every)],
               f"{TOPICS} processes, one stream each": [
                   (f"single{k}", sources[k]) for k in range(TOPICS)]}
    processes: list[subprocess.Popen[bytes]] = []
    stop = threading.Event()
    feed = threading.Thread(target=publisher, args=(endpoint, stop))
    try:
        processes.append(subprocess.Popen([wiswarm, "router", "-l", endpoint, *shm_off],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        time.sleep(1.0)
        feed.start()
        started = {name: [subprocess.Popen(
            [wiswarm, "follower", "--swarm", SWARM, "--id", robot, *flags, "-m", "client",
             "-e", endpoint, *shm_off], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for robot, flags in robots] for name, robots in layouts.items()}
        processes += [p for group in started.values() for p in group]
        spec = dataclasses.replace(SessionSpec.loopback("client", connect_ports=[port]),
                                   cfg=NO_SHM)
        with spec.open() as session, LeaderNode(session, SWARM, LeaderConfig()) as leader:
            time.sleep(seconds)
            members = len(leader.latest)
            memory = {name: sum(rss_kb(p.pid) for p in group) / 1024
                      for name, group in started.items()}
        base = memory["one process, one stream"]
        print(f"a robot's {TOPICS} topics (50 kB at 30 Hz each), every member polled by one "
              f"leader on loopback ({members} members), resident memory after {seconds:g} s:")
        for name, mb in memory.items():
            print(f"  {name:36s} {mb:6.1f} MB   {mb / base:4.2f}x")
        print(f"  target: one process of {TOPICS} streams <= 1.3x one of one stream")
    finally:
        stop.set()
        if feed.is_alive():
            feed.join()
        for process in reversed(processes):
            process.terminate()
            process.wait(10)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="polling window")
    parser.add_argument("--streams", action="store_true",
                        help="one process of four streams against one of one, four of one")
    args = parser.parse_args()
    if args.streams:
        streams(args.seconds)
        return
    port = free_tcp_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    wiswarm = os.path.join(os.path.dirname(sys.executable), "wiswarm")
    shm_off = ["--cfg", "transport/shared_memory/enabled:false", "--no-multicast-scouting"]
    router = subprocess.Popen([wiswarm, "router", "-l", endpoint, *shm_off],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    follower = None
    try:
        time.sleep(1.0)
        started = time.monotonic()
        follower = subprocess.Popen(
            [wiswarm, "follower", "--swarm", SWARM, "--id", "uav1", "-m", "client", "-e",
             endpoint, *shm_off], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        spec = dataclasses.replace(SessionSpec.loopback("client", connect_ports=[port]),
                                   cfg=NO_SHM)
        with spec.open() as session, LeaderNode(session, SWARM, LeaderConfig()) as leader:
            while leader.polls == 0:
                time.sleep(0.05)
            polls0, cpu0 = leader.polls, cpu_s(follower.pid)
            time.sleep(max(0.0, started + 10.0 - time.monotonic()))
            at_10s = rss_kb(follower.pid)
            time.sleep(max(0.0, args.seconds - 10.0))
            polls, cpu = leader.polls - polls0, cpu_s(follower.pid) - cpu0
            at_end = rss_kb(follower.pid)
        print(f"wiswarm follower (50 kB frames at 100 Hz), polled by a leader on loopback, "
              f"shared memory off (load average {', '.join(f'{x:.1f}' for x in os.getloadavg())}"
              f" on {os.cpu_count()} CPUs)")
        print(f"  resident memory 10 s after start   {at_10s / 1024:6.1f} MB   target <= 80 MB")
        print(f"  resident memory at the end          {at_end / 1024:6.1f} MB")
        print(f"  polls answered                      {polls:6d}   "
              f"({polls / args.seconds:.0f}/s)")
        print(f"  CPU per answered poll (process)     {cpu / max(polls, 1) * 1e6:6.1f} us")
        print(f"  heavy libraries loaded              {', '.join(loaded(follower.pid)) or 'none'}")
    finally:
        for process in (follower, router):
            if process is not None:
                process.terminate()
                process.wait(10)


if __name__ == "__main__":
    main()
