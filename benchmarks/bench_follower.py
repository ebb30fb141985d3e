"""A follower as light as the paper's UAV computer needs: ``wiswarm follower``'s memory
and its CPU per answered poll.

A router and one ``wiswarm follower`` process (synthetic frames, the defaults: 50 kB at
100 Hz) come up on loopback, shared memory off; a ``LeaderNode`` in this process polls
it. Printed: the follower's resident memory 10 s after its start (target: at most 80 MB)
and at the end, the CPU time of its process over the polling window per poll it
answered, and which heavy libraries it loaded (none of the tracking app's, the
dashboard's or ROS 2's should be).

    .venv/bin/python benchmarks/bench_follower.py
    .venv/bin/python benchmarks/bench_follower.py --seconds 20
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="polling window")
    args = parser.parse_args()
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
