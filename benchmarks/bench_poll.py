"""Polls per second: the leader's poll loop against a bare Zenoh ``get`` loop.

For each N, a router and N followers come up on loopback, each follower with a Zenoh
session of its own. By default the N sessions live in one host process (spawn), which
keeps each follower's code as warm as on a UAV of its own; ``--layout processes`` gives
each follower a process instead, as the demo does: on a machine with fewer cores than
processes, every poll then wakes a process whose caches the others have emptied, and
that cost of the test bed (S grows with N, in both loops) swamps what is measured. Every
follower serves two keys: a bare queryable answering with a fixed reply, and a
``FollowerNode`` that offers a frame at each poll (``sample_on_poll``: a camera read at
will, its capture cost left out), so each poll moves one whole fresh update, as the
bare reply does, with the same bytes on the wire (``--camera HZ`` instead feeds each
follower frames at that rate, as in the paper's runs: most polls then find nothing
new, so (b) shows the real system rather than a like-for-like comparison). Rounds of
(a) the bare loop (prepared queriers, round robin, one get in flight) and (b) the
``LeaderNode`` run in pairs back to back, (b) first in every other pair, so that the
machine's drift cancels, each timed from its 20th poll per follower on (steady state:
new queriers and routes are slow at first); the ratio (b)/(a) printed is the median
over the pairs (its quartiles show the noise), and so is the time (b) adds to each poll,
1/(b) - 1/(a), which the target allows up to 50 us; then the mean AoI of each
follower in (b) next to the round-robin floor S (N/2 + 1).

    .venv/bin/python benchmarks/bench_poll.py                 # N = 4 and 14, 50 kB
    .venv/bin/python benchmarks/bench_poll.py -n 4 --seconds 2 --control-period 0
    .venv/bin/python benchmarks/bench_poll.py --layout processes  # a process per follower
    .venv/bin/python benchmarks/bench_poll.py --secure   # mutual TLS + access control
    .venv/bin/python benchmarks/bench_poll.py --watch    # (c) with a delivery-stream reader

``--secure`` measures what closing the swarm costs: the ``LeaderNode`` of a swarm made by
``wiswarm security init`` (TLS-only router with access control, every node a client
with its own certificate) against the same leader in open swarms over TCP (clients of a
router, the same topology; and peers, as nodes run by default), in alternating rounds,
shared memory off everywhere (a network is meant: TLS never uses it).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import math
import multiprocessing
import os
import statistics
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import zenoh
from machine_cost import MachineCost
from poll_report import report, report_watched

from wiswarm_zenoh.core import Follower, FollowerConfig, LeaderConfig
from wiswarm_zenoh.core.wire import Poll, encode_poll
from wiswarm_zenoh.programs.frames import SyntheticFrames
from wiswarm_zenoh.programs.runners import (
    ReadySignal,
    StopSignal,
    run_child,
    run_router,
    wait_until_stopped,
)
from wiswarm_zenoh.security.acl import Roster
from wiswarm_zenoh.security.deploy import Plan, init
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SessionSpec
from wiswarm_zenoh.transport.stats_rounds import STATS_PERIOD
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

SWARM = "bench"
BARE = "benchbare"
READY_TIMEOUT = 30.0
WARM_UP_ROUNDS = 20  # polls per follower before either loop's clock starts: steady state


def serve_bare(session: zenoh.Session, follower: str, frame: bytes,
               stack: contextlib.ExitStack) -> None:
    """``follower``'s bare queryable: its FollowerNode's reply to a fresh ``frame``, fixed."""
    core = Follower(follower, FollowerConfig())  # what a FollowerNode answers, one frame
    core.offer(frame, time.time())
    reply = core.on_poll(encode_poll(Poll(1, time.time(), None)), time.time(), time.time())
    key = f"wiswarm/{BARE}/{follower}/update"

    def answer(query: zenoh.Query) -> None:
        with query:
            query.reply(key, reply)

    queryable = session.declare_queryable(key, zenoh.handlers.Callback(answer, indirect=False))
    stack.callback(queryable.undeclare)


def followers_process(specs: list[SessionSpec], followers: list[str], frame_bytes: int,
                      camera: float | None, bare: bool, stop: StopSignal,
                      ready: ReadySignal) -> None:
    """Followers of one host process, each with a Zenoh session of its own (as on a
    machine of its own, ``specs`` in order): the ``FollowerNode``, and with ``bare`` the
    bare queryable."""
    frame = bytes(frame_bytes)
    with contextlib.ExitStack() as stack:
        feeds = []
        for follower, spec in zip(followers, specs, strict=True):
            session = stack.enter_context(spec.open())
            if bare:
                serve_bare(session, follower, frame, stack)
            node = stack.enter_context(FollowerNode(
                session, SWARM, follower, sample_on_poll=None if camera else lambda: frame))
            if camera:
                feeds.append(SyntheticFrames(node.offer, frame_bytes, camera))
        for feed in feeds:
            feed.start()
            stack.callback(feed.stop)
        ready.set()
        wait_until_stopped(stop)


def wait_for_routes(session: zenoh.Session, followers: list[str], timeout: float) -> None:
    """Until every follower has answered a bare get: a fresh peer's routes take a while."""
    deadline = time.monotonic() + READY_TIMEOUT
    poll = encode_poll(Poll(1, time.time(), None))
    for follower in followers:
        while not any(reply.ok is not None for reply in session.get(
                f"wiswarm/{BARE}/{follower}/update", payload=poll, timeout=timeout)):
            if time.monotonic() > deadline:
                raise RuntimeError(f"{follower} does not answer")


def bare_round(session: zenoh.Session, followers: list[str], seconds: float,
               timeout: float, cost: MachineCost | None = None) -> float:
    """(a): polls/s of a round-robin get loop with nothing but Zenoh in it (and what
    its window cost the machine, into ``cost``)."""
    queriers = [
        session.declare_querier(
            f"wiswarm/{BARE}/{f}/update", target=zenoh.QueryTarget.ALL,
            consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout,
        )
        for f in followers
    ]
    poll = encode_poll(Poll(1, time.time(), None))
    polls, size = -WARM_UP_ROUNDS * len(queriers), 0  # the clock starts at polls == 0
    start = end = math.inf
    while time.perf_counter() < end:
        if polls == 0:
            if cost is not None:
                cost.begin()
            start = time.perf_counter()
            end = start + seconds
        for reply in queriers[polls % len(queriers)].get(payload=poll):
            sample = reply.ok
            if sample is not None:  # the next get at once, as the leader sends it: over
                size = len(sample.payload.to_bytes())  # TCP the get's end comes later
                break
        polls += 1
    elapsed = time.perf_counter() - start
    if cost is not None:
        cost.end(polls)
    for querier in queriers:
        querier.undeclare()
    if size == 0:
        raise RuntimeError("the bare loop got no reply")
    return polls / elapsed


def watched_round(session: zenoh.Session, watcher: SessionSpec, n: int, seconds: float,
                  config: LeaderConfig) -> tuple[float, float]:
    """(c): polls/s of the LeaderNode while another session subscribes to its delivery
    stream (``leader/deliveries``), and the records per second that session got."""
    records = [0]

    def count(sample: zenoh.Sample) -> None:
        records[0] += len(json.loads(sample.payload.to_bytes()))

    with watcher.open() as watching:  # its subscriber (held) goes with it
        _held = watching.declare_subscriber(f"wiswarm/{SWARM}/leader/deliveries", count)
        start = time.perf_counter()
        rate, _, _ = leader_round(session, n, seconds, config)
        return rate, records[0] / (time.perf_counter() - start)


def leader_round(session: zenoh.Session, n: int, seconds: float, config: LeaderConfig,
                 cost: MachineCost | None = None, **node: Any
                 ) -> tuple[float, list[dict[str, Any]], tuple[float, float]]:
    """(b): polls/s of the LeaderNode (made with ``node``'s further arguments), its
    per-follower stats at the end, and the shares of its polls sent on a pick made while
    the poll before was out (``fast_polls``) and, of all, before the reply before was
    judged (``early_polls``); what its window cost the machine, into ``cost``."""
    joined: list[str] = []
    everyone = threading.Event()

    def on_join(follower: str) -> None:
        joined.append(follower)
        if len(joined) == n:
            everyone.set()

    with LeaderNode(session, SWARM, config, on_join=on_join, every_record=True,
                    **node) as leader:
        if not everyone.wait(READY_TIMEOUT):
            raise RuntimeError(f"only {len(joined)} of {n} followers discovered")
        while leader.polls < WARM_UP_ROUNDS * n:
            time.sleep(0.001)
        if cost is not None:
            cost.begin()
        start, polls0 = time.perf_counter(), leader.polls
        fast0, early0 = leader.fast_polls, leader.early_polls
        time.sleep(seconds)
        polls = leader.polls - polls0
        fast, early = leader.fast_polls - fast0, leader.early_polls - early0
        rate = polls / (time.perf_counter() - start)
        if cost is not None:  # after the clock: reading /proc takes milliseconds
            cost.end(polls)
        time.sleep(STATS_PERIOD * 1.5)  # so that the last stats cover the whole round
        stats = [record.as_dict() for record in leader.latest]
    return rate, stats, (fast / max(polls, 1), early / max(polls, 1))


Job = tuple[Any, tuple[Any, ...]]


@contextlib.contextmanager
def children(jobs: list[Job]) -> Any:
    """Each job in a ``spawn`` child, up before the next starts; all stopped at the end.
    Yields their process ids, in order."""
    ctx = multiprocessing.get_context("spawn")
    procs = []
    try:
        for target, target_args in jobs:
            ready = ctx.Event()
            proc = ctx.Process(target=run_child, args=(target, target_args, ready))
            proc.start()
            procs.append(proc)
            if not ready.wait(READY_TIMEOUT):
                raise RuntimeError("a child process did not come up")
        yield [proc.pid for proc in procs]
    finally:
        for proc in procs:
            proc.terminate()
        for proc in procs:
            proc.join(10)
            if proc.is_alive():
                proc.kill()


def measure(n: int, args: argparse.Namespace) -> None:
    port = free_tcp_port()
    node_spec = SessionSpec.loopback(args.mode, connect_ports=[port])
    followers = [f"uav{i}" for i in range(n)]
    hosts = [followers] if args.layout == "host" else [[f] for f in followers]
    jobs: list[Job] = [
        (run_router, (SessionSpec.loopback("router", port),)),
        *((followers_process, ([node_spec] * len(names), names, args.frame_bytes, args.camera,
                               True)) for names in hosts),
    ]
    with children(jobs) as pids:
        config = LeaderConfig(policy=args.policy, timeout=args.timeout,
                              control_period=args.control_period)
        roles = {"router": pids[0], **{f"followers {i}": pid for i, pid in enumerate(pids[1:3])}}
        costs = {kind: MachineCost(roles) for kind in ("bare", "leader")}
        with node_spec.open() as session:
            wait_for_routes(session, followers, args.timeout)
            bare_round(session, followers, 0.5, args.timeout)  # warm up
            bare, leader, watched, stats, fast_shares = [], [], [], [], []
            kinds = ("bare", "leader", "watched") if args.watch else ("bare", "leader")
            for i in range(args.rounds):  # in turn, the order reversed every other time
                for kind in kinds if i % 2 == 0 else kinds[::-1]:  # so that drift cancels
                    if kind == "bare":
                        bare.append(bare_round(session, followers, args.seconds, args.timeout,
                                               costs["bare"]))
                    elif kind == "leader":
                        rate, stats, shares = leader_round(session, n, args.seconds, config,
                                                           costs["leader"])
                        leader.append(rate)
                        fast_shares.append(shares)
                    else:
                        watched.append(watched_round(session, node_spec, n, args.seconds,
                                                     config))
        report(n, args, bare, leader, stats, statistics.median(s[0] for s in fast_shares),
               statistics.median(s[1] for s in fast_shares))
        print("\n".join([*costs["bare"].lines("(a) bare get loop"),
                         *costs["leader"].lines("(b) leader loop")]))
        if watched:
            report_watched(leader, watched)


SWARMS = ("secured", "secured, no log", "open clients", "open peers")
NO_SHM = ("transport/shared_memory/enabled:false",)


def logging_router(spec: SessionSpec, stop: StopSignal, ready: ReadySignal) -> None:
    """The router as ``wiswarm router`` runs it: its log shows what access control refuses
    (which makes Zenoh trace every access-control decision, see ``zenoh_log``)."""
    run_router(spec, stop, ready, log_verbosity=0)


def swarm(kind: str, followers: list[str], args: argparse.Namespace,
          directory: Path) -> tuple[list[Job], SessionSpec]:
    """The processes of one swarm of ``kind`` (its router, its followers in one host
    process) and the session spec of its leader."""
    port = free_tcp_port()
    if kind.startswith("secured"):
        directory = directory / str(port)
        endpoint = (f"tls/127.0.0.1:{port}",)
        init(directory, Plan(Roster(SWARM, "leader", tuple(followers)), listen=endpoint,
                             connect=endpoint))
        router = SessionSpec(config_file=str(directory / "router.json5"))
        specs = [SessionSpec(config_file=str(directory / f"{f}.json5")) for f in followers]
        leader = SessionSpec(config_file=str(directory / "leader.json5"))
    else:
        router = dataclasses.replace(SessionSpec.loopback("router", port), cfg=NO_SHM)
        leader = dataclasses.replace(SessionSpec.loopback(
            "client" if kind == "open clients" else "peer", connect_ports=[port]), cfg=NO_SHM)
        specs = [leader] * len(followers)
    router_target = logging_router if kind == "secured" else run_router
    return [(router_target, (router,)),
            (followers_process, (specs, followers, args.frame_bytes, args.camera, False))], leader


def measure_secure(n: int, args: argparse.Namespace) -> None:
    """The leader's polls/s in a secured swarm and in open ones, rounds alternating."""
    followers = [f"uav{i}" for i in range(n)]
    config = LeaderConfig(policy=args.policy, timeout=args.timeout,
                          control_period=args.control_period)
    rates: dict[str, list[float]] = {kind: [] for kind in SWARMS}
    means: dict[str, list[float]] = {kind: [] for kind in SWARMS}
    with tempfile.TemporaryDirectory() as tmp:
        jobs, leaders = [], {}
        for kind in SWARMS:
            kind_jobs, leaders[kind] = swarm(kind, followers, args, Path(tmp) / "pki")
            jobs += kind_jobs
        with children(jobs), contextlib.ExitStack() as stack:
            sessions = {kind: stack.enter_context(leaders[kind].open()) for kind in SWARMS}
            for i in range(args.rounds):
                for kind in SWARMS if i % 2 == 0 else SWARMS[::-1]:
                    rate, stats, _ = leader_round(sessions[kind], n, args.seconds, config)
                    rates[kind].append(rate)
                    means[kind].append(statistics.mean(float(r["mean_aoi_s"]) for r in stats))
    print(f"\nN = {n}, {args.frame_bytes} B updates, {args.rounds} rounds of {args.seconds:g} s "
          f"per swarm, alternating; shared memory off (load average "
          f"{', '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} CPUs)")
    for kind in SWARMS:
        print(f"  {kind:15} {statistics.median(rates[kind]):8.0f} polls/s   mean AoI "
              f"{statistics.median(means[kind]) * 1e3:6.2f} ms   (rounds: "
              f"{', '.join(f'{x:.0f}' for x in rates[kind])})")
    for secured in SWARMS[:2]:
        for kind in SWARMS[2:]:
            paired = sorted(s / o for s, o in zip(rates[secured], rates[kind], strict=True))
            low, median, high = (statistics.quantiles(paired, n=4) if len(paired) > 1
                                 else paired * 3)
            print(f"  {secured + ' / ' + kind:31} {median:5.2f}   target >= 0.85   (median of "
                  f"{len(paired)} paired rounds, quartiles {low:.2f} .. {high:.2f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", "--followers", type=int, nargs="+", default=[4, 14])
    parser.add_argument("--frame-bytes", type=int, default=50176)
    parser.add_argument("--seconds", type=float, default=1.5, help="length of each round")
    parser.add_argument("--rounds", type=int, default=10, help="pairs of rounds")
    parser.add_argument("--camera", type=float, metavar="HZ",
                        help="followers make frames at this rate instead of one per poll")
    parser.add_argument("--mode", choices=["peer", "client"], default="peer")
    parser.add_argument("--layout", choices=["host", "processes"], default="host",
                        help="the followers' sessions in one host process (default), or a "
                        "process per follower")
    parser.add_argument("--policy", default="whittle")
    parser.add_argument("--timeout", type=float, default=0.3)
    parser.add_argument("--control-period", type=float, default=0.1,
                        help="seconds between repeats of unchanged control (0: every poll)")
    parser.add_argument("--watch", action="store_true",
                        help="(c): also the leader with a subscriber to its delivery stream")
    parser.add_argument("--secure", action="store_true",
                        help="a secured swarm's leader against open swarms' (see above)")
    args = parser.parse_args()
    for n in args.followers:
        (measure_secure if args.secure else measure)(n, args)


if __name__ == "__main__":
    main()
