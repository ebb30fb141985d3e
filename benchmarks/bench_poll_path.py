"""Where a poll's time goes: the leader's loop against the bare get loop, step by step.

``bench_poll.py`` says how many polls per second the leader makes of what the bare get
loop makes; this says which step of a poll the difference is in, so that a change can
aim at it. Each poll is cut in three, timed in the same set-up as ``bench_poll`` (a
router and N followers in one host process, 50 kB updates, one poll out at a time):

Three loops: (a) the bare loop of ``bench_poll``, (a') the same loop polling the
followers' ``FollowerNode``s (the follower's side of a poll, with nothing of the
leader's), and (b) the ``LeaderNode``.

- **get call**: the ``get`` call itself (Zenoh's binding sends the query);
- **round trip**: from the ``get`` call's return to the reply in the poller's hands
  (the wire, the follower's answer, the wake-up of the waiting thread);
- **reply to next get**: from the reply in hand to the next ``get`` call (the bare
  loop only takes the sample; the leader reads the reply's header, weighs the pick it
  made ahead and encodes the next poll, ``Leader.poll_on_answer``, and judges the reply
  after that get: ``the core's receive_reply``, off this step where the header decided).

The leader's steps are timed by wrapping its functions (two clock reads each, about a
microsecond in all), so its rate here is a little under ``bench_poll``'s. Last, (c)
times the core's two calls on the critical path with nothing else running: what the
same Python costs when no Zenoh thread shares the cores and caches.

    .venv/bin/python benchmarks/bench_poll_path.py          # N = 4, 3 s per loop
    .venv/bin/python benchmarks/bench_poll_path.py -n 14 --seconds 5
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import zenoh
from bench_poll import (
    BARE,
    SWARM,
    WARM_UP_ROUNDS,
    children,
    followers_process,
    leader_round,
    run_router,
    wait_for_routes,
)

from wiswarm_zenoh.core import Follower, Leader, LeaderConfig
from wiswarm_zenoh.core.wire import Poll, encode_poll
from wiswarm_zenoh.transport import SessionSpec, leader_node, links
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

Steps = dict[str, list[float]]  # step -> its durations (seconds), one per poll


def bare_steps(session: zenoh.Session, followers: list[str], seconds: float,
               timeout: float, swarm: str = BARE) -> Steps:
    """The bare get loop (round robin over prepared queriers), each poll's steps; of
    ``swarm``'s followers: the bare queryables', or the ``FollowerNode``s' (whose core
    answers each poll with a fresh update, as the leader's polls find it)."""
    queriers = [session.declare_querier(
        f"wiswarm/{swarm}/{f}/update", target=zenoh.QueryTarget.ALL,
        consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout) for f in followers]
    poll = encode_poll(Poll(1, time.time(), None))
    steps: Steps = {"get call": [], "round trip": [], "reply to next get": []}
    clock, polls, end, replied = time.perf_counter, 0, time.perf_counter() + seconds, None
    while clock() < end:
        sent = clock()
        if replied is not None and polls > WARM_UP_ROUNDS * len(queriers):
            steps["reply to next get"].append(sent - replied)
        replies = queriers[polls % len(queriers)].get(payload=poll)
        returned = clock()
        for reply in replies:
            if reply.ok is not None:
                replied = clock()
                steps["get call"].append(returned - sent)
                steps["round trip"].append(replied - returned)
                break
        polls += 1
    for querier in queriers:
        querier.undeclare()
    return steps


def leader_steps(session: zenoh.Session, n: int, seconds: float) -> Steps:
    """The LeaderNode's steady polls, each one's steps (its functions wrapped meanwhile)."""
    clock = time.perf_counter
    marks: list[tuple[str, float, float]] = []  # ("reply" or "get", start, end)

    def timed(kind: str, function: Callable[..., Any]) -> Callable[..., Any]:
        def wrapper(*args: Any) -> Any:
            start = clock()
            result = function(*args)
            marks.append((kind, start, clock()))
            return result
        return wrapper

    answer, get = leader_node.LeaderNode._answer, links.FollowerLink.poll_steady
    judge = Leader.receive_reply
    leader_node.LeaderNode._answer = timed("reply", answer)  # type: ignore[method-assign]
    links.FollowerLink.poll_steady = timed("get", get)  # type: ignore[method-assign]
    Leader.receive_reply = timed("judge", judge)  # type: ignore[method-assign]
    try:
        leader_round(session, n, seconds, LeaderConfig(control_period=0.1))
    finally:
        leader_node.LeaderNode._answer = answer  # type: ignore[method-assign]
        links.FollowerLink.poll_steady = get  # type: ignore[method-assign]
        Leader.receive_reply = judge  # type: ignore[method-assign]
    steps: Steps = {"get call": [], "round trip": [], "reply to next get": [],
                    "the core's receive_reply (after that get)": []}
    last_get: tuple[float, float] | None = None
    last_reply: tuple[float, float] | None = None
    marks.sort(key=lambda mark: mark[1])  # (the next get is made inside the reply's call)
    for kind, start, end in marks[len(marks) // 4:]:  # steady state: the first quarter out
        if kind == "judge":
            steps["the core's receive_reply (after that get)"].append(end - start)
        elif kind == "reply":
            if last_get is not None:
                steps["round trip"].append(start - last_get[1])
                steps["get call"].append(last_get[1] - last_get[0])
            last_reply, last_get = (start, end), None
        else:
            if last_reply is not None:
                steps["reply to next get"].append(start - last_reply[0])
            last_get, last_reply = (start, end), None
    return steps


def core_alone(n: int, frame_bytes: int, polls: int = 20_000) -> Steps:
    """The core's own share, with no Zenoh and no other thread: a ``Leader`` and ``n``
    ``Follower`` cores exchanging polls by hand, 250 us apart on the clock given them,
    as the live leader does: the next poll on the answer where it decides it, else by
    ``next_poll`` after the judging."""
    leader = Leader(LeaderConfig(control_period=0.1), None, 1)
    followers = {f"uav{i}": Follower(f"uav{i}") for i in range(n)}
    now, frame, clock = 1000.0, b"\x42" * frame_bytes, time.perf_counter
    for follower in followers:
        leader.add_follower(follower, now)
    steps: Steps = {"next_poll": [], "poll_on_answer": [], "receive_reply": []}
    request = leader.next_poll(now)
    for k in range(polls):
        assert request is not None  # (no source paced here: a poll is always due)
        core = followers[request.follower]
        core.offer(frame, now + 50e-6)
        raw = core.on_poll(request.payload, now + 100e-6, now + 100e-6)
        now += 250e-6
        leader.next_poll(now)  # none while one is out: the pick for after it, as live
        received = clock()
        following = leader.poll_on_answer(request.follower, raw, now)
        answered = clock()
        leader.receive_reply(request.follower, raw, now)
        done = clock()
        if following is None:
            following = leader.next_poll(now)
            if k >= polls // 5:
                steps["next_poll"].append(clock() - done)
        elif k >= polls // 5:
            steps["poll_on_answer"].append(answered - received)
        while leader.next_event() is not None:
            pass
        if k >= polls // 5:
            steps["receive_reply"].append(done - answered)
        request = following
    return steps


def report(name: str, steps: Steps) -> None:
    polls = max(len(durations) for durations in steps.values())
    print(f"  {name} ({polls} polls timed)")
    for step, durations in steps.items():
        if not durations:
            continue
        print(f"    {step:34s} median {statistics.median(durations) * 1e6:7.1f} us"
              f"   mean {statistics.mean(durations) * 1e6:7.1f} us")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-n", "--followers", type=int, default=4)
    parser.add_argument("--frame-bytes", type=int, default=50176)
    parser.add_argument("--seconds", type=float, default=3.0, help="length of each loop")
    args = parser.parse_args()
    port = free_tcp_port()
    spec = SessionSpec.loopback("peer", connect_ports=[port])
    followers = [f"uav{i}" for i in range(args.followers)]
    jobs = [(run_router, (SessionSpec.loopback("router", port),)),
            (followers_process, ([spec] * args.followers, followers, args.frame_bytes, None,
                                 True))]
    with children(jobs), spec.open() as session:
        wait_for_routes(session, followers, 0.3)
        bare = bare_steps(session, followers, args.seconds, 0.3)
        nodes = bare_steps(session, followers, args.seconds, 0.3, SWARM)
        leader = leader_steps(session, args.followers, args.seconds)
    print(f"N = {args.followers}, {args.frame_bytes} B updates: each poll's steps")
    report("(a) bare get loop", bare)
    report("(a') bare get loop, answered by the FollowerNodes", nodes)
    report("(b) leader loop, steady polls", leader)
    report("(c) the leader's core alone", core_alone(args.followers, args.frame_bytes))
    for step in ("get call", "round trip", "reply to next get"):
        follower = statistics.median(nodes[step]) - statistics.median(bare[step])
        leader_side = statistics.median(leader[step]) - statistics.median(nodes[step])
        print(f"  {step:18s} the follower's node adds {follower * 1e6:6.1f} us, "
              f"the leader's {leader_side * 1e6:6.1f} us")


if __name__ == "__main__":
    main()
