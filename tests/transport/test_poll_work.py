"""The leader's work per poll, counted rather than timed (a guard against creep).

Speed is measured in benchmarks (``bench_poll``, ``bench_scale``); this test counts what
the poll threads do per poll in steady state: the Python functions they call and the
C functions (builtins, Zenoh's methods) they call, through ``sys.setprofile``. The
counts do not depend on the machine or its load, so the ceilings sit a little above
what the leader needs today: the day someone adds work to the per-poll path, this
fails, wherever it runs. What comes by the clock rather than by the poll is kept out of
the window: stats rounds (a few a second, whatever the poll rate), and the other poll
thread's wakes at each poll's deadline (a floor of 0.5 s makes them a few a second too).
"""

from __future__ import annotations

import sys
import threading
from types import FrameType

import zenoh

from wiswarm_zenoh.core import Delivered, LeaderConfig
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

from .helpers import WAIT, Sessions

SWARM = "work"
FOLLOWERS = 4
WARM_UP = 200  # deliveries before counting: routes, queriers and estimates settled
COUNTED = 1000  # deliveries counted
PYTHON_CALLS_CEILING = 90  # per poll; measured: 83 (pure Python core, 4 followers)
C_CALLS_CEILING = 100  # per poll; measured: 88 to 94


class PollThreadCalls:
    """Counts the calls the leader's poll threads make while ``counting`` is set."""

    def __init__(self, swarm: str) -> None:
        self._prefix = f"leader-{swarm}/"
        self.counting = False
        self.python = 0
        self.c = 0

    def install(self) -> None:
        """For the threads started from now on (the leader's, as it is made)."""
        threading.setprofile(self._first)

    def _first(self, frame: FrameType, event: str, arg: object) -> None:
        mine = threading.current_thread().name.startswith(self._prefix)
        sys.setprofile(self._count if mine else None)

    def _count(self, frame: FrameType, event: str, arg: object) -> None:
        if self.counting:
            if event == "call":
                self.python += 1
            elif event == "c_call":
                self.c += 1


class Deliveries:
    """A callback as light as an application's can be; ``reached`` set at ``target``."""

    def __init__(self) -> None:
        self.n = 0
        self.target = WARM_UP
        self.reached = threading.Event()

    def on_delivery(self, event: Delivered) -> None:
        self.n += 1
        if self.n == self.target:
            self.reached.set()

    def wait_for(self, target: int) -> None:
        self.target, self.reached = target, threading.Event()
        assert self.reached.wait(WAIT), f"only {self.n} of {target} deliveries"


def test_the_poll_path_does_no_more_than_it_needs(
    sessions: Sessions, router: zenoh.Session, port: int
) -> None:
    for i in range(FOLLOWERS):
        FollowerNode(sessions.node(port), SWARM, f"uav{i}", sample_on_poll=lambda: bytes(1000))
    calls, deliveries = PollThreadCalls(SWARM), Deliveries()
    calls.install()
    try:
        leader = LeaderNode(sessions.node(port), SWARM,
                            LeaderConfig(timeout_floor=0.5, timeout=1.0),
                            on_delivery=deliveries.on_delivery, stats_period=3600.0)
    finally:
        threading.setprofile(None)  # type: ignore[arg-type]
    with leader:
        assert deliveries.reached.wait(WAIT), "no steady state"
        polls0 = leader.polls
        calls.counting = True
        deliveries.wait_for(deliveries.n + COUNTED)
        calls.counting = False
        polls = leader.polls - polls0
    python, c = calls.python / polls, calls.c / polls
    print(f"per poll: {python:.1f} Python calls, {c:.1f} C calls over {polls} polls")
    assert python <= PYTHON_CALLS_CEILING, f"{python:.1f} Python calls per poll"
    assert c <= C_CALLS_CEILING, f"{c:.1f} C calls per poll"
