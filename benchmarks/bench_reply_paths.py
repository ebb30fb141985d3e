"""Reply paths: which way of receiving a Zenoh reply gives a poller the most round trips/s.

The leader keeps exactly one query in flight: the moment the reply to the current get
is in, it sends the next get, to the next follower, round robin over N followers. How
fast that loop turns depends on how the reply reaches the code that sends the next get.
This benchmark runs the same loop with five reply paths over the same followers, so that
the leader's poll loop can be built on the fastest:

  A   FIFO (the default handler): a poll thread iterates ``for reply in querier.get()``,
      takes the first ok reply and sends the next get at once (the get is not waited
      out to its close).
  B   A ``Callback(on_reply, on_drop, indirect=False)`` run on Zenoh's own thread puts
      (tag, reply) into one ``queue.SimpleQueue``, and (tag, None) when the get closes;
      the poll thread takes them with ``inbox.get(timeout=...)``, skips what belongs to
      an older get, and sends the next get.
  B2  As B, without the drop callback: a get that never answers is caught by the
      timeout of ``inbox.get``.
  B3  As B, but the drop callback posts only for a get that brought no ok reply (the
      only end that is news): the leader's path.
  C   No thread hop at all: the reply callback (indirect=False, on Zenoh's thread)
      itself calls the next querier's ``get`` with a new callback; the drop callback
      moves the chain on when a get closed without an ok reply. The main thread only
      waits for the round's end and stops the chain.
  C2  As C, without the drop callback: what the close of every get costs C. Not a design
      on its own: a get that never answers would end the chain (the round then fails
      as hung).
  D   As B, with ``indirect=True``: zenoh-python's own Python thread runs the callback
      (zenoh-python 1.10 starts a ``threading.Thread`` for each such callback, so for
      every get).

Every path takes the reply's bytes once (``reply.ok.payload.to_bytes()``), as the leader
must. A router listens on tcp/127.0.0.1; N followers, each a Zenoh session of its own
in one separate host process (``spawn``), serve a queryable each, declared with
``Callback(..., indirect=False)``, answering every get with ``--reply-bytes`` bytes; the
poller connects to the router (peer or client, ``--mode``). Multicast scouting is off
and shared memory is off on every session (else replies of 3 kB or more would travel
through shared memory, which a network never does). The queriers are declared once per
follower (target ALL, no consolidation, ``--timeout``) and shared by every path.

Rounds of every path run interleaved (A B B2 C C2 D, then D C2 C B2 B A, ...) so that
the machine's drift hits them alike; each round is timed from its ``--warm-up``-th poll
per follower on. For each path the table gives the median polls/s over the rounds with
its quartiles and the round trip it means (1/median: one get in flight), the ratio to A
(the median over the rounds of path/A of the same pass, with quartiles), the CPU time of
the whole poller process (every thread, Zenoh's too) per poll and per second of wall
time (all paths run in this same process: ``time.process_time`` deltas over each timed
window), and how many gets of the timed windows got no ok reply.

On a machine with few cores the router and the followers share them with the poller, so
a path's CPU per poll slows every path's round trip, not only its own.

    .venv/bin/python benchmarks/bench_reply_paths.py                  # N = 4 and 14
    .venv/bin/python benchmarks/bench_reply_paths.py -n 4 --rounds 4 --variants A C
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import zenoh
from bench_poll import NO_SHM, Job, children
from reply_pollers import POLL, ChainPoller, FifoPoller, Poller, QueuePoller

from wiswarm_zenoh.programs.runners import (
    ReadySignal,
    StopSignal,
    run_router,
    wait_until_stopped,
)
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

KEY = "wiswarm/benchreply/{}/update"
READY_TIMEOUT = 30.0


# --- the followers ------------------------------------------------------------------


def followers_process(spec: SessionSpec, followers: list[str], reply_bytes: int,
                      stop: StopSignal, ready: ReadySignal) -> None:
    """N followers in one host process, each a session of its own with a queryable that
    answers on Zenoh's thread with ``reply_bytes`` bytes."""
    reply = bytes(reply_bytes)
    with contextlib.ExitStack() as stack:
        for follower in followers:
            session = stack.enter_context(spec.open())
            key = KEY.format(follower)

            def answer(query: zenoh.Query, key: str = key) -> None:
                with query:
                    query.reply(key, reply)

            queryable = session.declare_queryable(
                key, zenoh.handlers.Callback(answer, indirect=False))
            stack.callback(queryable.undeclare)
        ready.set()
        wait_until_stopped(stop)


@dataclass(frozen=True)
class Variant:
    name: str
    label: str
    make: Callable[[Sequence[zenoh.Querier], float], Poller]


VARIANTS = {
    v.name: v for v in (
        Variant("A", "FIFO, poll thread iterates", FifoPoller),
        Variant("B", "Callback direct + drop -> SimpleQueue",
                lambda q, t: QueuePoller(q, t, drop=True, indirect=False)),
        Variant("B2", "Callback direct, no drop -> SimpleQueue",
                lambda q, t: QueuePoller(q, t, drop=False, indirect=False)),
        Variant("B3", "Callback direct + drop only without an ok reply -> SimpleQueue",
                lambda q, t: QueuePoller(q, t, drop=True, indirect=False, quiet_drop=True)),
        Variant("C", "next get from the reply callback + drop", ChainPoller),
        Variant("C2", "next get from the reply callback, no drop",
                lambda q, t: ChainPoller(q, t, drop=False)),
        Variant("D", "Callback indirect + drop -> SimpleQueue",
                lambda q, t: QueuePoller(q, t, drop=True, indirect=True)),
    )
}


# --- measuring ----------------------------------------------------------------------


@dataclass
class Results:
    rates: list[float] = field(default_factory=list)  # polls/s, one per round
    cpu: list[float] = field(default_factory=list)  # process CPU s per poll
    load: list[float] = field(default_factory=list)  # process CPU s per wall s
    failed: int = 0  # gets without an ok reply in the timed windows
    polls: int = 0


def run_round(variant: Variant, queriers: Sequence[zenoh.Querier], seconds: float,
              warm_up: int, timeout: float) -> tuple[float, float, float, int, int]:
    """One round of ``variant``: polls/s, CPU s per poll, CPU s per s, failed, polls."""
    poller = variant.make(queriers, timeout)
    poller.start()
    try:
        deadline = time.monotonic() + READY_TIMEOUT
        while poller.polls < warm_up:
            if poller.error is not None or time.monotonic() > deadline:
                raise RuntimeError(f"{variant.name}: no steady state "
                                   f"({poller.polls} polls, error {poller.error!r})")
            time.sleep(0.002)
        t0, c0, p0, f0 = time.perf_counter(), time.process_time(), poller.polls, poller.failed
        time.sleep(seconds)
        t1, c1, p1, f1 = time.perf_counter(), time.process_time(), poller.polls, poller.failed
    finally:
        stopped = poller.stop()
    if not stopped:
        raise RuntimeError(f"{variant.name}: the poller did not stop (hung)")
    if poller.error is not None:
        raise RuntimeError(f"{variant.name}: {poller.error!r}") from poller.error
    if poller.size == 0:
        raise RuntimeError(f"{variant.name}: no reply payload taken")
    polls = p1 - p0
    if polls <= 0:
        raise RuntimeError(f"{variant.name}: no poll in the timed window")
    return polls / (t1 - t0), (c1 - c0) / polls, (c1 - c0) / (t1 - t0), f1 - f0, polls


def wait_for_routes(session: zenoh.Session, followers: list[str], timeout: float) -> None:
    """Until every follower has answered a get: a fresh peer's routes take a while."""
    deadline = time.monotonic() + READY_TIMEOUT
    for follower in followers:
        while not any(reply.ok is not None for reply in session.get(
                KEY.format(follower), payload=POLL, timeout=timeout)):
            if time.monotonic() > deadline:
                raise RuntimeError(f"{follower} does not answer")


def measure(n: int, args: argparse.Namespace) -> dict[str, Results]:
    port = free_tcp_port()
    router = dataclasses.replace(SessionSpec.loopback("router", port), cfg=NO_SHM)
    node = dataclasses.replace(SessionSpec.loopback(args.mode, connect_ports=[port]),
                               cfg=NO_SHM)
    followers = [f"uav{i}" for i in range(n)]
    jobs: list[Job] = [(run_router, (router,)),
                       (followers_process, (node, followers, args.reply_bytes))]
    variants = [VARIANTS[name] for name in args.variants]
    results = {v.name: Results() for v in variants}
    warm_up = args.warm_up * n
    with children(jobs), node.open() as session:
        wait_for_routes(session, followers, args.timeout)
        queriers = [
            session.declare_querier(
                KEY.format(f), target=zenoh.QueryTarget.ALL,
                consolidation=zenoh.ConsolidationMode.NONE, timeout=args.timeout,
            )
            for f in followers
        ]
        try:
            for variant in variants:  # warm up every path once, untimed
                run_round(variant, queriers, 0.3, warm_up, args.timeout)
            for i in range(args.rounds):
                for variant in variants if i % 2 == 0 else variants[::-1]:
                    rate, cpu, load, failed, polls = run_round(
                        variant, queriers, args.seconds, warm_up, args.timeout)
                    result = results[variant.name]
                    result.rates.append(rate)
                    result.cpu.append(cpu)
                    result.load.append(load)
                    result.failed += failed
                    result.polls += polls
                if args.verbose:
                    print(f"  round {i + 1}: " + ", ".join(
                        f"{v.name} {results[v.name].rates[-1]:.0f}" for v in variants),
                        flush=True)
        finally:
            for querier in queriers:
                querier.undeclare()  # type: ignore[no-untyped-call]
    report(n, args, variants, results)
    return results


def quartiles(values: Sequence[float]) -> tuple[float, float, float]:
    if len(values) < 2:
        return values[0], values[0], values[0]
    low, median, high = statistics.quantiles(values, n=4)
    return low, median, high


def report(n: int, args: argparse.Namespace, variants: list[Variant],
           results: dict[str, Results]) -> None:
    load_avg = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"\nN = {n}, {args.reply_bytes} B replies, {args.mode} mode via a router, followers "
          f"in one host process, shared memory off, {args.rounds} rounds of "
          f"{args.seconds:g} s per path, interleaved (load average {load_avg} on "
          f"{os.cpu_count()} CPUs)")
    print(f"  {'path':4} {'':42} {'polls/s':>8} {'(q1 .. q3)':>15} {'us/poll':>7}  {'/ A':>5} "
          f"{'(q1 .. q3)':>13}  {'CPU us/poll':>11} {'CPU s/s':>7}  {'no reply':>8}")
    base = results[variants[0].name].rates if variants[0].name == "A" else None
    for v in variants:
        r = results[v.name]
        q1, _, q3 = quartiles(r.rates)
        median = statistics.median(r.rates)
        if base is not None:
            ratios = [x / a for x, a in zip(r.rates, base, strict=True)]
            rq1, _, rq3 = quartiles(ratios)
            ratio = f"{statistics.median(ratios):5.2f} ({rq1:5.2f} .. {rq3:5.2f})"
        else:
            ratio = f"{'-':>5} {'':13}"
        print(f"  {v.name:4} {v.label:42} {median:8.0f} ({q1:6.0f} .. {q3:6.0f}) "
              f"{1e6 / median:7.0f}  {ratio}  "
              f"{statistics.median(r.cpu) * 1e6:11.0f} {statistics.median(r.load):7.2f}  "
              f"{r.failed:>8}")
    print("  rounds (polls/s): " + "; ".join(
        f"{v.name} " + " ".join(f"{x:.0f}" for x in results[v.name].rates) for v in variants))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-n", "--followers", type=int, nargs="+", default=[4, 14],
                        help="numbers of followers, one measurement each (default 4 14)")
    parser.add_argument("--rounds", type=int, default=8, help="rounds per path (default 8)")
    parser.add_argument("--seconds", type=float, default=1.5,
                        help="timed length of each round (default 1.5)")
    parser.add_argument("--warm-up", type=int, default=20, metavar="POLLS",
                        help="polls per follower before a round's clock starts (default 20)")
    parser.add_argument("--reply-bytes", type=int, default=50176,
                        help="bytes of each reply (default 50176: a 224x224 RGB frame)")
    parser.add_argument("--mode", choices=["peer", "client"], default="peer",
                        help="session mode of the poller and the followers (default peer)")
    parser.add_argument("--timeout", type=float, default=0.3,
                        help="the queriers' timeout in seconds (default 0.3)")
    parser.add_argument("--variants", nargs="+", choices=list(VARIANTS),
                        default=list(VARIANTS), help="paths to run (default all); ratios "
                        "are against the first, when it is A")
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="print each round's rates as it ends")
    args = parser.parse_args()
    if args.rounds < 1 or args.seconds <= 0:
        parser.error("--rounds must be >= 1 and --seconds > 0")
    try:
        for n in args.followers:
            measure(n, args)
    except RuntimeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
