"""A weight raised on one of four equal members, measured over the tbf channel (issue 42,
root): does that member's mean AoI fall by at least 30 % within 5 s?

Four followers (``wiswarm follower``, synthetic 30 Hz cameras of 50 kB frames, a process
and a Zenoh session each, in the channel's follower namespace) and the CLI leader
(``wiswarm leader --record``) with its router in the leader namespace, over the 20
Mbit/s tbf channel (200 ms queue). After a steady period the weight of ``uav0`` is put
on its weight key, ``wiswarm/bench/uav0/weight``, as a tool of the leader's side would.
Reported per member from the leader's record of every delivery (one host: the
followers' stamps are the host's clock, the leader's offsets 0): mean AoI over the
``--before`` seconds before the change and over ``--after`` seconds from ``--settle``
seconds after it, and its two parts (the frames' age at delivery, the sawtooth between
deliveries), frames taken per second and the leader's polls per second (its stats,
with the polls that found nothing new), and ``uav0``'s AoI second by second around the
change. With ``--flag-runs`` also two static runs, without and with ``--weight uav0=W``
from the start (as the command line sets it); with ``--sim`` first the same index in
the simulator's model of the link (virtual time, no root). About 3 minutes with both.

    .venv/bin/python benchmarks/bench_weight.py --sim --flag-runs
    .venv/bin/python benchmarks/bench_weight.py --weight 9 --before 15 --after 15
"""

from __future__ import annotations

import argparse
import itertools
import json
import logging
import os
import random
import statistics
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import zenoh

from wiswarm_zenoh.core import LeaderConfig
from wiswarm_zenoh.experiments.cli_processes import Cli, start_cli, stop_cli
from wiswarm_zenoh.experiments.testbed_study import FRAME_OVERHEAD
from wiswarm_zenoh.programs.zenoh_log import LOG_FORMAT
from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.link import LinkMedium, LinkScenario, SocketUdpPush, ZenohAirtime
from wiswarm_zenoh.sim.metrics import FollowerMetrics
from wiswarm_zenoh.sim.scenario import start_system
from wiswarm_zenoh.sim.wiswarm import WiswarmNetwork
from wiswarm_zenoh.testbed import check_available
from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.netns import entered
from wiswarm_zenoh.testbed.nodes import ROUTER_PORT
from wiswarm_zenoh.testbed.run import read_record, window_metrics
from wiswarm_zenoh.testbed.spec import ChannelSpec
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

SWARM = "bench"
KEYS = SwarmKeys(SWARM)
RAISED = "uav0"
JOIN_WAIT = 60.0  # seconds for every follower to join


@dataclass
class Stats:
    """The leader's stats as they come: each member's last record, and the summary."""

    members: dict[str, dict[str, float]] = field(default_factory=dict)
    followers: list[str] = field(default_factory=list)
    cond: threading.Condition = field(default_factory=threading.Condition)

    def on_sample(self, sample: zenoh.Sample) -> None:
        record = json.loads(sample.payload.to_bytes())
        with self.cond:
            if str(sample.key_expr) == KEYS.leader_stats:
                self.followers = list(record["followers"])
            else:
                self.members[record["follower"]] = record
            self.cond.notify_all()

    def wait(self, what: str, check: Callable[[], bool], timeout: float) -> None:
        with self.cond:
            if not self.cond.wait_for(check, timeout):
                raise SystemExit(f"bench_weight: timed out waiting for {what}")

    def snapshot(self) -> dict[str, dict[str, float]]:
        with self.cond:
            return {member: dict(record) for member, record in self.members.items()}


@dataclass
class Run:
    """One run's record and what happened when (wall clock, the leader's)."""

    record: Path
    members: list[str]
    joined: float
    changed: float | None = None  # when the weight was put
    taken_after: float | None = None  # until the leader's stats showed it
    polls: dict[str, tuple[dict[str, dict[str, float]], float]] = field(default_factory=dict)
    load: list[float] = field(default_factory=list)  # 1-min load average, start and end


def fly(args: argparse.Namespace, channel: Channel, out: Path, tag: str,
        flag_weight: float | None, put_weight: float | None) -> Run:
    """Start router, leader and followers from the command line on ``channel``, and fly:
    the steady period, the put (``put_weight``), the window after it. (The operator's
    session opens in the leader namespace: Zenoh's runtime stays where this process's
    first session started it, so every run takes the same channel.)"""
    members = [f"uav{i}" for i in range(args.followers)]
    logs = out / f"{tag}-logs"
    logs.mkdir(parents=True, exist_ok=True)
    record = out / f"{tag}.csv"
    clis: list[Cli] = []
    router = f"tcp/{channel.leader_addr}:{ROUTER_PORT}"
    local = f"tcp/127.0.0.1:{ROUTER_PORT}"
    try:
        clis.append(start_cli(channel.leader_ns, [
            "router", "-l", router, "-l", local, "--no-multicast-scouting"], logs, "router"))
        flags = [] if flag_weight is None else ["--weight", f"{RAISED}={flag_weight:g}"]
        clis.append(start_cli(channel.leader_ns, [
            "leader", "--swarm", SWARM, "-e", local, "--no-multicast-scouting",
            "--record", str(record), *flags], logs, "leader"))
        for member in members:
            clis.append(start_cli(channel.follower_ns, [
                "follower", "--swarm", SWARM, "--id", member, "--rate", f"{args.rate:g}",
                "--frame-bytes", str(args.frame_bytes), "-e", router,
                "--no-multicast-scouting"], logs, member))
        with entered(channel.leader_ns):  # the operator: a tool of the leader's side
            session = SessionSpec(mode="peer", connect=(local,),
                                  multicast_scouting=False).open()
        with session:
            return _fly(args, session, record, members, put_weight)
    finally:
        stop_cli(list(reversed(clis)))


def _fly(args: argparse.Namespace, session: zenoh.Session, record: Path,
         members: list[str], put_weight: float | None) -> Run:
    stats = Stats()
    subscribers = [session.declare_subscriber(key, stats.on_sample)
                   for key in (KEYS.all_stats, KEYS.leader_stats)]
    try:
        stats.wait("every follower to join", lambda: sorted(stats.followers) == members,
                   JOIN_WAIT)
        run = Run(record, members, time.time(), load=[os.getloadavg()[0]])
        before_end = run.joined + args.warmup + args.before
        time.sleep(max(0.0, before_end - args.before - time.time()))  # the steady period
        run.polls["start"] = (stats.snapshot(), time.time())
        time.sleep(max(0.0, before_end - time.time()))
        run.polls["change"] = (stats.snapshot(), time.time())
        run.load.append(os.getloadavg()[0])
        if put_weight is None:  # a static run: the window before is all
            return run
        run.changed = time.time()
        session.put(KEYS.weight(RAISED), f"{put_weight:g}")
        stats.wait("the weight in the leader's stats",
                   lambda: stats.members.get(RAISED, {}).get("weight") == put_weight, 10.0)
        run.taken_after = time.time() - run.changed
        time.sleep(max(0.0, run.changed + args.settle - time.time()))
        run.polls["settled"] = (stats.snapshot(), time.time())
        time.sleep(max(0.0, run.changed + args.settle + args.after - time.time()))
        run.polls["end"] = (stats.snapshot(), time.time())
        run.load.append(os.getloadavg()[0])
        return run
    finally:
        undeclare(*subscribers)


def window(run: Run, t0: float, t1: float, frame_bytes: int) -> dict[str, FollowerMetrics]:
    rows = read_record(run.record)
    return {m.follower: m for m in window_metrics(rows, run.members, run.joined, t0, t1,
                                                  frame_bytes)}


def parts(run: Run, t0: float, t1: float) -> dict[str, tuple[float, float]]:
    """Per member, the two parts of its mean AoI over [t0, t1] (deliveries within):
    the frames' mean age at delivery, and E[g^2] / 2 E[g] of the gaps g between
    deliveries (the sawtooth's mean rise; half the mean gap were they even)."""
    out = {}
    for member, rows in read_record(run.record).items():
        inside = sorted((d, g) for d, g in rows if t0 <= d <= t1)
        gaps = [b[0] - a[0] for a, b in itertools.pairwise(inside)]
        out[member] = (statistics.mean(d - g for d, g in inside),
                       sum(g * g for g in gaps) / (2 * sum(gaps)))
    return out


def rates(run: Run, first: str, last: str) -> dict[str, tuple[float, float]]:
    """Per member: polls/s and polls finding nothing new per second, between two
    snapshots of the leader's stats."""
    (a, ta), (b, tb) = run.polls[first], run.polls[last]
    out = {}
    for member in run.members:
        polls = b[member]["polls"] - a[member]["polls"]
        found = (b[member]["deliveries"] + b[member]["timeouts"]) - \
            (a[member]["deliveries"] + a[member]["timeouts"])
        out[member] = (polls / (tb - ta), (polls - found) / (tb - ta))
    return out


def change_report(args: argparse.Namespace, run: Run) -> list[str]:
    assert run.changed is not None
    t = run.changed
    before = window(run, t - args.before, t, args.frame_bytes)
    after = window(run, t + args.settle, t + args.settle + args.after, args.frame_bytes)
    polls_before, polls_after = rates(run, "start", "change"), rates(run, "settled", "end")
    parts_before = parts(run, t - args.before, t)
    parts_after = parts(run, t + args.settle, t + args.settle + args.after)
    lines = [f"weight {args.weight:g} put on {KEYS.weight(RAISED)} at t = "
             f"{t - run.joined:.1f} s after every follower joined; the leader's stats "
             f"showed it {1e3 * (run.taken_after or 0.0):.0f} ms later",
             f"windows: before [-{args.before:g} s, 0], after [+{args.settle:g} s, "
             f"+{args.settle + args.after:g} s]; load average {run.load[0]:.2f}, "
             f"{run.load[1]:.2f}, {run.load[2]:.2f} (start, change, end); the leader's "
             "clock offsets of the followers (its record's generation times are their "
             "stamps less these): " + ", ".join(
                 f"{record['clock_offset_s'] * 1e3:.2f} ms"
                 for record in run.polls["end"][0].values()), "",
             "| member | mean AoI before (ms) | after (ms) | change | age at delivery "
             "before, after (ms) | E[g^2]/2E[g] before, after (ms) | frames/s before | "
             "after | polls/s before | after | empty polls/s before | after |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for member in run.members:
        b, a = before[member], after[member]
        (pb, eb), (pa, ea) = polls_before[member], polls_after[member]
        (db, rb), (da, ra) = parts_before[member], parts_after[member]
        lines.append(f"| {member}{' (raised)' if member == RAISED else ''} | "
                     f"{b.mean_aoi_s * 1e3:.1f} | {a.mean_aoi_s * 1e3:.1f} | "
                     f"{100 * (a.mean_aoi_s / b.mean_aoi_s - 1):+.0f} % | "
                     f"{db * 1e3:.1f}, {da * 1e3:.1f} | {rb * 1e3:.1f}, {ra * 1e3:.1f} | "
                     f"{b.throughput_fps:.1f} | {a.throughput_fps:.1f} | {pb:.1f} | {pa:.1f} "
                     f"| {eb:.1f} | {ea:.1f} |")
    others = [m for m in run.members if m != RAISED]
    mean_before = sum(before[m].mean_aoi_s for m in others) / len(others)
    mean_after = sum(after[m].mean_aoi_s for m in others) / len(others)
    fall = 1 - after[RAISED].mean_aoi_s / before[RAISED].mean_aoi_s
    frame_s = args.frame_bytes * 8 * FRAME_OVERHEAD / ChannelSpec().rate_bps
    floor = frame_s + 0.5 / args.rate
    lines += ["", f"{RAISED}'s mean AoI {before[RAISED].mean_aoi_s * 1e3:.1f} -> "
              f"{after[RAISED].mean_aoi_s * 1e3:.1f} ms: a fall of {100 * fall:.1f} % "
              f"(target >= 30 % within {args.settle:g} s: "
              f"{'met' if fall >= 0.30 else 'missed'}); the others' "
              f"{mean_before * 1e3:.1f} -> {mean_after * 1e3:.1f} ms "
              f"({100 * (mean_after / mean_before - 1):+.1f} %)",
              f"its floor, every frame taken the moment it is ready: one frame's time on "
              f"the link + half the camera's interval = {frame_s * 1e3:.1f} + "
              f"{500 / args.rate:.1f} = {floor * 1e3:.1f} ms, a fall of "
              f"{100 * (1 - floor / before[RAISED].mean_aoi_s):.0f} % at most; it took "
              f"{after[RAISED].throughput_fps:.1f} of its camera's {args.rate:g} frames/s",
              "",
              f"{RAISED}'s mean AoI second by second from the change (ms):"]
    seconds = range(-3, int(min(args.settle + 5, args.settle + args.after)))
    series = [window(run, t + k, t + k + 1, args.frame_bytes)[RAISED].mean_aoi_s * 1e3
              for k in seconds]
    lines.append("  " + "  ".join(f"{k:+d}: {v:.0f}" for k, v in zip(seconds, series,
                                                                        strict=True)))
    return lines


def static_report(args: argparse.Namespace, runs: Sequence[Run]) -> list[str]:
    lines = ["", f"static runs ({args.before:g} s each after {args.warmup:g} s): "
             f"--weight {RAISED}={args.weight:g} from the start against none", "",
             "| run | " + " | ".join(f"{m} mean AoI (ms), frames/s" for m in runs[0].members)
             + " |", "|---|" + "---|" * len(runs[0].members)]
    for label, run in zip(("no --weight", f"--weight {RAISED}={args.weight:g}"), runs,
                          strict=True):
        t0 = run.joined + args.warmup
        metrics = window(run, t0, t0 + args.before, args.frame_bytes)
        lines.append(f"| {label} | " + " | ".join(
            f"{metrics[m].mean_aoi_s * 1e3:.1f}, {metrics[m].throughput_fps:.1f}"
            for m in run.members) + " |")
    return lines


def simulated(args: argparse.Namespace, weight: float, seed: int) -> list[tuple[float, float]]:
    """(mean AoI s, frames/s) per member: the same index and cameras in the simulator's
    model of the tbf link (virtual time, ground truth), ``RAISED`` weighing ``weight``
    from the start."""
    scenario = LinkScenario(n=args.followers, frame_bytes=args.frame_bytes,
                            sample_rate=args.rate, duration=args.sim_seconds, seed=seed,
                            price_by_time=LeaderConfig().price_by_time)
    rng = random.Random(scenario.seed)
    engine = Engine(rng.getrandbits(64))
    medium = LinkMedium(engine, scenario.link)  # as run_link builds it
    leader = medium.station("leader", downlink=True)
    stations = [medium.station(f"uav{i}", None) for i in range(scenario.n)]
    sinks, net = start_system(scenario, engine, medium, ZenohAirtime(scenario.link), leader,
                              stations, [1.0] * scenario.n, rng, SocketUdpPush)
    assert isinstance(net, WiswarmNetwork)
    net.leader.set_weight(RAISED, weight)
    engine.run(scenario.duration)
    return [(sink.mean(scenario.duration), sink.deliveries / scenario.duration)
            for sink in sinks]


def sim_report(args: argparse.Namespace) -> list[str]:
    lines = ["", f"the simulator (wiswarm sim link's model, {args.sim_seconds:g} s of virtual "
             f"time, seeds 0-2, {RAISED}'s weight from the start):", "",
             f"| {RAISED}'s weight | {RAISED} mean AoI (ms) | frames/s | the others' (ms) | "
             "frames/s |", "|---|---|---|---|---|"]
    for weight in (1.0, args.weight):
        runs = [simulated(args, weight, seed) for seed in range(3)]
        raised = [run[0] for run in runs]
        others = [member for run in runs for member in run[1:]]
        lines.append(f"| {weight:g} | {statistics.mean(a for a, _ in raised) * 1e3:.1f} | "
                     f"{statistics.mean(f for _, f in raised):.1f} | "
                     f"{statistics.mean(a for a, _ in others) * 1e3:.1f} | "
                     f"{statistics.mean(f for _, f in others):.1f} |")
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--followers", type=int, default=4)
    parser.add_argument("--rate", type=float, default=30.0, help="camera frames/s")
    parser.add_argument("--frame-bytes", type=int, default=50_000)
    parser.add_argument("--weight", type=float, default=4.0, help="uav0's new weight")
    parser.add_argument("--warmup", type=float, default=10.0, help="s after every join")
    parser.add_argument("--before", type=float, default=30.0, help="window before (s)")
    parser.add_argument("--settle", type=float, default=5.0,
                        help="s from the change to the after window")
    parser.add_argument("--after", type=float, default=30.0, help="window after (s)")
    parser.add_argument("--flag-runs", action="store_true",
                        help="also two static runs, without and with --weight")
    parser.add_argument("--sim", action="store_true",
                        help="also the same in the simulator (virtual time, no root)")
    parser.add_argument("--sim-seconds", type=float, default=60.0)
    parser.add_argument("--out", type=Path, help="keep the records and logs here")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING, format=LOG_FORMAT)
    if args.sim:
        print("\n".join(sim_report(args)), flush=True)
    check_available()
    print(f"bench_weight: {args.followers} followers ({args.rate:g} Hz, {args.frame_bytes} B "
          f"frames, wiswarm follower) over tbf 20mbit (200 ms queue), wiswarm leader; "
          f"{RAISED}'s weight to {args.weight:g}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        with Channel(ChannelSpec()) as channel:
            run = fly(args, channel, out, "change", None, args.weight)
            print("\n".join(change_report(args, run)), flush=True)
            if args.flag_runs:
                static = [fly(args, channel, out, tag, weight, None)
                          for tag, weight in (("plain", None), ("flag", args.weight))]
                print("\n".join(static_report(args, static)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
