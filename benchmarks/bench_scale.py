"""One leader, hundreds of followers on loopback: discovery, fairness, AoI, leader cost.

For each N a router comes up, then the N followers spread over ``--hosts`` host
processes (spawn). The followers of a host share one Zenoh session: a session costs a
few MB and several threads, so a thousand of them do not fit a small machine. Each
follower is a ``FollowerNode`` answering every poll with a fresh frame of
``--frame-bytes`` taken then (``sample_on_poll``), beside a bare queryable answering with
the same bytes; each still subscribes to control on its own, so a host decodes every
control message once per follower it hosts (``--control-period`` sets how often the
leader repeats it). Shared
memory is off everywhere (``transport/shared_memory/enabled: false``) and multicast
scouting too, as in ``bench_poll.py``.

The leader runs in this process, in a session of its own: the time from its start to
the N-th join (discovery, tokens already there) and to the first delivery of every
follower; then over a window of ``--seconds``: polls/s, S = 1/(polls/s), deliveries per
follower (min, max, spread), each follower's mean AoI over the window against the
round-robin floor S (N/2 + 1) with that S, and what the leader costs: this process's
RSS growth since before its session opened, per follower, and its CPU time (all
threads, Zenoh's included; the two poll threads' alone beside it) per second and per
follower, beside the whole machine's. Also shown: polls that timed out (on a 2-core
machine hosting a thousand followers, a host descheduled past the 10 ms timeout floor
makes a poll time out, and the leader then rightly polls that follower less for its next
``window`` polls: ``--timeout-floor`` tells that apart from the scheduler), and the
leader's garbage-collector pauses. Last, a bare round-robin ``get`` loop over the same
followers (prepared queriers, one get in flight) gives Zenoh's own S for comparison.
``--profile K`` prints the poll threads' top K functions by CPU time (cProfile).
``--reask-pairs K`` then measures what asking again for the followers' tokens costs
(``transport/discovery``: a liveliness get answered for all N, at its pace): K pairs of
windows of ``--reask-seconds``, asking on in one and off in the other, in alternating
order; the median of the pairs' polls/s ratio (off / on) is the cost.

    .venv/bin/python benchmarks/bench_scale.py                  # N = 100, 300, 1000
    .venv/bin/python benchmarks/bench_scale.py -n 1000 --seconds 5 --profile 25
    .venv/bin/python benchmarks/bench_scale.py -n 1000 --seconds 5 --reask-pairs 8
"""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import dataclasses
import os
import pstats
import statistics
import sys
import threading
import time
from functools import partial

import zenoh
from bench_poll import BARE, NO_SHM, Job, children, serve_bare, wait_for_routes
from machine_cost import MachineCost
from scale_probes import Pauses, machine_busy, process_cpu, rss_bytes, thread_cpu
from scale_watch import Watch, window_figures

from wiswarm_zenoh.core import LeaderConfig
from wiswarm_zenoh.core.wire import Poll, encode_poll
from wiswarm_zenoh.programs.runners import (
    ReadySignal,
    StopSignal,
    run_router,
    wait_until_stopped,
)
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SessionSpec
from wiswarm_zenoh.transport.stats_rounds import STATS_PERIOD
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

SWARM = "bench"
DISCOVERY_TIMEOUT = 120.0


def host_process(spec: SessionSpec, followers: list[str], frame_bytes: int,
                 stop: StopSignal, ready: ReadySignal) -> None:
    """The followers of one host: one session, a ``FollowerNode`` and a bare queryable
    per follower."""
    frame = bytes(frame_bytes)
    with spec.open() as session, contextlib.ExitStack() as stack:
        for follower in followers:
            serve_bare(session, follower, frame, stack)
            stack.enter_context(FollowerNode(session, SWARM, follower,
                                             sample_on_poll=lambda: frame))
        ready.set()
        wait_until_stopped(stop)


def profile_poll_thread(profilers: list[cProfile.Profile], *_: object) -> None:
    """``threading.setprofile`` hook: the first call in each new thread; profiles only the
    leader's poll threads, each with a profiler of its own (Zenoh starts Python threads
    for its callbacks too)."""
    sys.setprofile(None)
    if threading.current_thread().name.startswith(f"leader-{SWARM}/"):
        profiler = cProfile.Profile(time.thread_time)
        profilers.append(profiler)
        profiler.enable()


@dataclasses.dataclass
class Window:
    seconds: float
    polls: int
    cpu: float  # the whole process
    machine: float  # every process, the hosts and the router included
    poll_thread_cpu: float
    counts: dict[str, int]
    mean_aoi: dict[str, float]
    timeouts: int  # polls that went unanswered, from the leader's stats (a round apart)
    pauses: Pauses
    fast: int  # polls sent on the pick made while the poll before was out
    early: int  # of them, before the reply before was judged


def leader_run(spec: SessionSpec, followers: list[str], args: argparse.Namespace,
               seconds: float, profilers: list[cProfile.Profile] | None, cost: MachineCost,
               ) -> tuple[float, float, int, int, Window]:
    """Discovery, then the measuring window; returns the time to all joins and to every
    follower's first delivery, the RSS growth after discovery and at the end, and the
    window (what it cost the machine into ``cost``)."""
    n = len(followers)
    watch = Watch(followers)
    rss0 = rss_bytes()
    with spec.open() as session:
        if profilers is not None:  # each poll thread enables its own as it starts
            threading.setprofile(partial(profile_poll_thread, profilers))
        start = time.perf_counter()
        config = LeaderConfig(policy=args.policy, timeout=args.timeout,
                              timeout_floor=args.timeout_floor,
                              control_period=args.control_period)
        with LeaderNode(session, SWARM, config,
                        on_join=watch.on_join, on_delivery=watch.on_delivery) as node:
            threading.setprofile(None)
            poll_threads = [t.native_id for t in threading.enumerate()
                            if t.name.startswith(f"leader-{SWARM}/") and t.native_id]
            if not watch.all_joined.wait(DISCOVERY_TIMEOUT):
                raise RuntimeError(f"only {watch.joined} of {n} followers discovered")
            joined = time.perf_counter() - start
            if not watch.all_delivered.wait(DISCOVERY_TIMEOUT):
                raise RuntimeError(f"only {len(watch.delivered)} of {n} followers delivered")
            polled = time.perf_counter() - start
            rss_joined = rss_bytes() - rss0
            time.sleep(args.warmup)
            timeouts0 = timeouts(node, session)  # before the window: the records cost CPU
            t0, polls0, fast0, early0 = time.time(), node.polls, node.fast_polls, \
                node.early_polls
            cpu0, thread0 = process_cpu(), thread_cpu(poll_threads)
            machine0 = machine_busy()
            pauses = Pauses()
            cost.begin()
            time.sleep(seconds)
            pauses.close()
            t1, polls1, fast1, early1 = time.time(), node.polls, node.fast_polls, \
                node.early_polls
            cost.end(polls1 - polls0)
            cpu1, thread1 = process_cpu(), thread_cpu(poll_threads)
            machine1 = machine_busy()
            rss_end = rss_bytes() - rss0
            timeouts1 = timeouts(node, session)  # after it
            if args.reask_pairs:
                reask_cost(node, args.reask_pairs, args.reask_seconds)
    counts, means = window_figures(watch, followers, t0, t1)
    return joined, polled, rss_joined, rss_end, Window(
        t1 - t0, polls1 - polls0, cpu1 - cpu0, machine1 - machine0, thread1 - thread0,
        counts, means,
        timeouts1 - timeouts0, pauses, fast1 - fast0, early1 - early0)


def reask_cost(node: LeaderNode, pairs: int, seconds: float) -> None:
    """Polls/s with the followers' tokens asked for again (at the default pace) and
    without, in alternating windows; prints the median ratio and the asks made."""
    period, off = node.discovery.period, 1e9
    ratios, rates = [], {period: [], off: []}
    asks_on, time_on = 0, 0.0
    for pair in range(pairs):
        rate = {}
        for pace in (period, off) if pair % 2 == 0 else (off, period):
            node.discovery.period = pace
            time.sleep(0.5)  # an answer of the other pace still coming is in
            polls, asks, start = node.polls, node.discovery.reasks, time.perf_counter()
            time.sleep(seconds)
            took = time.perf_counter() - start
            rate[pace] = (node.polls - polls) / took
            rates[pace].append(rate[pace])
            if pace == period:
                asks_on, time_on = asks_on + node.discovery.reasks - asks, time_on + took
        ratios.append(rate[off] / rate[period])
    node.discovery.period = period
    quartiles = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else ratios * 3
    print(f"  asking again ({asks_on / time_on:.2f} asks/s): "
          f"{statistics.median(rates[period]):.0f} polls/s, off: "
          f"{statistics.median(rates[off]):.0f}; off/on median {statistics.median(ratios):.3f}"
          f" (quartiles {quartiles[0]:.3f} .. {quartiles[2]:.3f}, {pairs} pairs of "
          f"{seconds:g} s; {node.discovery.found_by_answer} tokens found by asking)"
          f"   target <= 1.02", flush=True)


def timeouts(node: LeaderNode, session: zenoh.Session) -> int:
    """Unanswered polls so far, from the followers' stats records: made only while a
    subscriber matches, so one is declared for a few rounds outside the window."""
    subscriber = session.declare_subscriber(f"wiswarm/{SWARM}/*/stats", lambda sample: None)
    try:
        time.sleep(3 * STATS_PERIOD)
        return sum(record.timeouts for record in node.latest)
    finally:
        subscriber.undeclare()


def bare_rate(spec: SessionSpec, followers: list[str], seconds: float,
              timeout: float, cost: MachineCost) -> tuple[float, float, float]:
    """Polls/s of a round-robin get loop with nothing but Zenoh in it (after two rounds
    of warm-up), and the CPU time of its thread and of this process per poll (what it
    cost the machine into ``cost``)."""
    with spec.open() as session:
        wait_for_routes(session, followers, timeout)
        queriers = [session.declare_querier(
            f"wiswarm/{BARE}/{f}/update", target=zenoh.QueryTarget.ALL,
            consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout) for f in followers]
        poll = encode_poll(Poll(1, time.time(), None))
        polls, start, end, cpu, process = -2 * len(queriers), 0.0, float("inf"), 0.0, 0.0
        while time.perf_counter() < end:
            if polls == 0:
                cost.begin()
                start, cpu, process = time.perf_counter(), time.thread_time(), time.process_time()
                end = start + seconds
            for _ in queriers[polls % len(queriers)].get(payload=poll):
                pass
            polls += 1
        figures = (polls / (time.perf_counter() - start), (time.thread_time() - cpu) / polls,
                   (time.process_time() - process) / polls)
        cost.end(polls)
        return figures


def measure(n: int, args: argparse.Namespace) -> None:
    seconds = args.seconds or max(10.0, 0.03 * n)
    port = free_tcp_port()
    router = dataclasses.replace(SessionSpec.loopback("router", port), cfg=NO_SHM)
    node = dataclasses.replace(SessionSpec.loopback(args.mode, connect_ports=[port]),
                               cfg=NO_SHM)
    followers = [f"uav{i}" for i in range(n)]
    hosts = [followers[h::args.hosts] for h in range(min(args.hosts, n))]
    jobs: list[Job] = [(run_router, (router,)),
                       *((host_process, (node, names, args.frame_bytes)) for names in hosts)]
    # CPU time of the thread, not wall time: waits and preemption by other processes
    # (2 cores, a router and the hosts) would swamp what the poll thread itself costs.
    profilers: list[cProfile.Profile] | None = [] if args.profile else None
    up = time.perf_counter()
    with children(jobs) as pids:
        up = time.perf_counter() - up
        roles = {"router": pids[0], **{f"host {i}": pid for i, pid in enumerate(pids[1:])}}
        costs = {kind: MachineCost(roles) for kind in ("leader", "bare")}
        joined, polled, rss_joined, rss_end, window = leader_run(node, followers, args, seconds,
                                                                 profilers, costs["leader"])
        bare = bare_rate(node, followers, args.bare_seconds, args.timeout, costs["bare"]) \
            if args.bare_seconds > 0 else None
    report(n, args, up, joined, polled, rss_joined, rss_end, window, bare)
    print("\n".join([*costs["leader"].lines("leader"),
                     *(costs["bare"].lines("bare get loop") if bare is not None else [])]))
    if profilers:
        print(f"\n  poll threads' profile (whole run, cProfile: slower than unprofiled), "
              f"top {args.profile} by own time:")
        pstats.Stats(*profilers).sort_stats("tottime").print_stats(args.profile)


def report(n: int, args: argparse.Namespace, up: float, joined: float, polled: float,
           rss_joined: int, rss_end: int, window: Window,
           bare: tuple[float, float, float] | None) -> None:
    rate = window.polls / window.seconds
    s = 1.0 / rate
    floor = s * (n / 2 + 1)
    counts = sorted(window.counts.values())
    low, high, mean_count = counts[0], counts[-1], statistics.mean(counts)
    ratios = sorted(a / floor for a in window.mean_aoi.values())
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"\nN = {n}: {args.hosts} host processes (one session each), {args.mode} mode via "
          f"a router, {args.frame_bytes} B frames sampled on poll, {args.policy}, timeout floor "
          f"{args.timeout_floor * 1e3:g} ms, shared "
          f"memory off, control repeated every {args.control_period:g} s; window "
          f"{window.seconds:.1f} s after {args.warmup:g} s of warm-up (load average {load} on "
          f"{os.cpu_count()} CPUs)")
    print(f"  followers up (spawn, sessions, declarations)  {up:8.2f} s")
    print(f"  discovery: all {n} joins seen by the leader    {joined:8.2f} s   target < 10 s")
    print(f"  every follower delivered once                 {polled:8.2f} s")
    print(f"  leader polls/s                                {rate:8.0f}       S = "
          f"{s * 1e3:.3f} ms" + ("" if bare is None else
                                f"   (bare get loop: {bare[0]:.0f} polls/s, S = "
                                f"{1e3 / bare[0]:.3f} ms; leader/bare {rate / bare[0]:.2f})"))
    print(f"  sent on the pick made while the poll before was out   "
          f"{window.fast / max(window.polls, 1):6.1%}   (before it was judged "
          f"{window.early / max(window.polls, 1):.1%})")
    gcs = window.pauses
    print(f"  polls unanswered (timed out)                  {window.timeouts:8d}       "
          f"leader's GC pauses: " + ", ".join(
              f"gen {g} {gcs.count[g]}x up to {gcs.longest[g] * 1e3:.1f} ms" for g in range(3)))
    print(f"  deliveries per follower  min {low}  max {high}  mean {mean_count:.1f}  "
          f"spread (max-min)/mean {(high - low) / mean_count:.1%}  max/min "
          f"{high / max(low, 1):.2f}   (round robin: +-1)")
    print(f"  mean AoI / floor S(N/2+1) = {floor * 1e3:.1f} ms:  mean "
          f"{statistics.mean(ratios):.3f}  median {statistics.median(ratios):.3f}  "
          f"worst {ratios[-1]:.3f}   target <= 1.3")
    print(f"  leader RSS since before its session  {rss_joined / 2**20:7.1f} MB after "
          f"discovery, {rss_end / 2**20:7.1f} MB at the end = {rss_end / n / 1024:6.1f} kB "
          f"per follower")
    print(f"  leader CPU (process, all threads)    {window.cpu / window.seconds:6.1%} of a core "
          f"= {window.cpu / window.seconds / n * 1e6:7.1f} us/s per follower, "
          f"{window.cpu / window.polls * 1e6:6.1f} us per poll"
          + ("" if bare is None else f" (bare get loop: {bare[2] * 1e6:.1f})"))
    print(f"  poll threads alone                   {window.poll_thread_cpu / window.seconds:6.1%}"
          f" of a core = {window.poll_thread_cpu / window.seconds / n * 1e6:7.1f} us/s per "
          f"follower, {window.poll_thread_cpu / window.polls * 1e6:6.1f} us per poll"
          + ("" if bare is None else f" (bare get loop: {bare[1] * 1e6:.1f})"))
    busy = window.machine / window.seconds
    print(f"  the whole machine meanwhile          {busy:6.1%} of a core busy (of "
          f"{os.cpu_count()}: hosts, router, leader, anything else)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", "--followers", type=int, nargs="+", default=[100, 300, 1000])
    parser.add_argument("--hosts", type=int, default=4, help="follower host processes")
    parser.add_argument("--frame-bytes", type=int, default=1000)
    parser.add_argument("--seconds", type=float,
                        help="measuring window (default: 10 s, or 0.03 s per follower if "
                        "longer: some 30 polls each, so that round robin's +-1 is 3 %%)")
    parser.add_argument("--warmup", type=float, default=2.0,
                        help="seconds between every follower's first delivery and the window")
    parser.add_argument("--bare-seconds", type=float, default=3.0,
                        help="length of the bare get loop (0: skip it)")
    parser.add_argument("--mode", choices=["peer", "client"], default="peer")
    parser.add_argument("--policy", default="whittle")
    parser.add_argument("--timeout", type=float, default=0.3)
    parser.add_argument("--timeout-floor", type=float, default=LeaderConfig.timeout_floor,
                        help="the shortest adaptive timeout (a host descheduled longer "
                        "makes a poll time out, and its follower is polled less for a while)")
    parser.add_argument("--control-period", type=float, default=LeaderConfig.control_period,
                        help="seconds between repeats of unchanged control (each wakes every "
                        "follower of every host)")
    parser.add_argument("--reask-pairs", type=int, default=0, metavar="K",
                        help="pairs of windows with asking again on and off (default 0)")
    parser.add_argument("--reask-seconds", type=float, default=3.0,
                        help="length of each of those windows")
    parser.add_argument("--profile", type=int, default=0, metavar="K",
                        help="cProfile the leader's poll thread and print its top K functions")
    args = parser.parse_args()
    for n in args.followers:
        measure(n, args)


if __name__ == "__main__":
    main()
