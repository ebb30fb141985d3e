"""How often a leader misses a follower that is there: the guide's two-router layout.

Why: in Zenoh's peer mode a liveliness answer can lack a token that is there, and a
leader whose one liveliness subscriber missed a follower's token never polled it
(issue 40). This counts joins the way a user sees them: real ``wiswarm`` processes, a
robot router that dials the ground's, the follower on the robot's router and the leader
on the ground's, each by ``-e``, with busy loops beside them. A trial is a miss when
the leader has not logged ``follower <id> joined`` within ``--within`` seconds of the
moment both were up (each process's ready line: the interpreter's start, slow on a busy
host, is not discovery's).

Two kinds of trial, as a robot and a ground under systemd see them:

- ``restart``: the follower stays up; the leader is started, then stopped, again and
  again;
- ``together``: follower and leader are started at the same moment, then both stopped.

    .venv/bin/python benchmarks/bench_discovery.py --modes peer client --trials 20 --busy 1
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import statistics
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from bench_liveliness_answers import busy_loops

from wiswarm_zenoh.testbed.faults import Process
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

SWARM, FOLLOWER = "s1", "d1"
JOINED = f"follower {FOLLOWER} joined"
READY = "(Ctrl-C to stop)"  # the end of a node's ready line
START_WITHIN = 30.0  # seconds a process may take to be up on a busy host


def node(args: Sequence[str]) -> Process:
    """A ``wiswarm`` process as a user starts it, its output read line by line."""
    return Process(args[0] if args[0] != "-v" else args[1], args,
                   {**os.environ, "PYTHONUNBUFFERED": "1"})


@dataclass
class Layout:
    """The two routers of the guide: the robot's (its follower's) dials the ground's."""

    mode: str
    ground: int = field(default_factory=free_tcp_port)
    robot: int = field(default_factory=free_tcp_port)

    def routers(self) -> list[Process]:
        ground = node(["router", "-l", f"tcp/127.0.0.1:{self.ground}",
                       "--no-multicast-scouting"])
        robot = node(["router", "-l", f"tcp/127.0.0.1:{self.robot}", "-e",
                      f"tcp/127.0.0.1:{self.ground}", "--no-multicast-scouting"])
        for router in (ground, robot):
            if router.when("listening on", 30) is None:
                raise RuntimeError("a router did not start:\n" + "\n".join(router.lines))
        return [ground, robot]

    def _flags(self, port: int) -> list[str]:
        return ["-m", self.mode, "-e", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"]

    def follower(self) -> Process:
        return node(["follower", "--swarm", SWARM, "--id", FOLLOWER, *self._flags(self.robot)])

    def leader(self) -> Process:
        return node(["-v", "leader", "--swarm", SWARM, *self._flags(self.ground)])


@dataclass
class Trials:
    """Join times (seconds from the moment both were up) and misses, of one kind of
    trial."""

    joins: list[float] = field(default_factory=list)
    misses: int = 0

    def line(self, name: str) -> str:
        count = len(self.joins) + self.misses
        times = (f"join median {statistics.median(self.joins):.2f} s, slowest "
                 f"{max(self.joins):.2f} s" if self.joins else "no join")
        return f"{name:9s} {self.misses} of {count} missed; {times}"


def _joined(leader: Process, follower_up: float, within: float, trials: Trials,
            log: list[str]) -> None:
    """A join within ``within`` of the moment both were up, or a miss."""
    leader_up = leader.when(READY, START_WITHIN)
    if leader_up is None:
        raise RuntimeError("the leader did not start:\n" + "\n".join(leader.lines))
    both_up = max(leader_up, follower_up)
    joined = leader.when(JOINED, both_up + within - time.monotonic())
    if joined is not None and joined - both_up <= within:
        trials.joins.append(max(0.0, joined - both_up))
    else:
        trials.misses += 1
        log.extend(leader.lines[-20:])


def _up(process: Process, what: str) -> float:
    up = process.when(READY, START_WITHIN)
    if up is None:
        raise RuntimeError(f"the {what} did not start:\n" + "\n".join(process.lines))
    return up


def restarts(layout: Layout, count: int, within: float, log: list[str]) -> Trials:
    """The follower up throughout; the leader started ``count`` times."""
    trials = Trials()
    follower = layout.follower()
    try:
        follower_up = _up(follower, "follower")
        for _ in range(count):
            leader = layout.leader()
            try:
                _joined(leader, follower_up, within, trials, log)
            finally:
                leader.stop()
    finally:
        follower.stop()
    return trials


def together(layout: Layout, count: int, within: float, log: list[str]) -> Trials:
    """Follower and leader started at once, ``count`` times."""
    trials = Trials()
    for _ in range(count):
        follower, leader = layout.follower(), layout.leader()
        try:
            _joined(leader, _up(follower, "follower"), within, trials, log)
        finally:
            leader.stop()
            follower.stop()
    return trials


def run(mode: str, count: int, within: float, log: list[str]) -> tuple[Trials, Trials]:
    layout = Layout(mode)
    routers = layout.routers()
    try:
        return restarts(layout, count, within, log), together(layout, count, within, log)
    finally:
        for router in reversed(routers):
            router.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--modes", nargs="+", choices=["peer", "client"],
                        default=["peer", "client"], help="the nodes' session mode")
    parser.add_argument("--trials", type=int, default=20, help="trials of each kind")
    parser.add_argument("--within", type=float, default=2.0,
                        help="seconds a join may take before it counts as missed")
    parser.add_argument("--busy", type=int, default=1, help="busy loops beside (default 1)")
    parser.add_argument("--check", action="store_true", help="exit 1 if any trial missed")
    args = parser.parse_args()
    missed = 0
    print(f"eclipse-zenoh {importlib.metadata.version('eclipse-zenoh')}, {args.busy} busy "
          f"loops beside; a miss: no join within {args.within:g} s", flush=True)
    with busy_loops(args.busy):
        for mode in args.modes:
            log: list[str] = []
            restarted, started = run(mode, args.trials, args.within, log)
            print(f"{mode}:\n  {restarted.line('restart')}\n  {started.line('together')}",
                  flush=True)
            missed += restarted.misses + started.misses
            if log:
                print("  a missed leader's last lines:\n    " + "\n    ".join(log[-20:]))
    if args.check and missed:
        sys.exit(1)


if __name__ == "__main__":
    main()
