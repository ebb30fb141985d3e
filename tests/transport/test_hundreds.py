"""A hundred followers on loopback: every one is polled, and equal weights share evenly."""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.core import Delivered, LeaderConfig
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

from .helpers import WAIT, Sessions

SWARM = "hundreds"
N = 100
ROUNDS = 6  # deliveries the least served follower gets in the measured window
FRAME = bytes(1000)


class Tally:
    """Deliveries per follower, waitable (``Recorder``'s pattern, with a count per
    follower: a predicate over a hundred followers runs on every delivery)."""

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()
        self.cond = threading.Condition()

    def on_delivery(self, event: Delivered) -> None:
        with self.cond:
            self.counts[event.follower] += 1
            self.cond.notify_all()

    def wait(self, what: str, predicate: Callable[[Counter[str]], bool]) -> Counter[str]:
        """Until ``predicate`` holds of the counts; a copy of them then."""
        with self.cond:
            assert self.cond.wait_for(lambda: predicate(self.counts), WAIT), \
                f"timed out: {what} ({len(self.counts)} followers delivered)"
            return Counter(self.counts)


def test_a_hundred_followers_sharing_a_session_are_all_delivered_evenly(
    sessions: Sessions, router: zenoh.Session, port: int
) -> None:
    """All hundred followers of one host session are delivered; over the next rounds no
    follower gets more than 1.5 times what the least served one got (with equal
    weights and every poll answered, whittle polls the oldest first: round robin,
    so +-1 around the mean)."""
    host = sessions.node(port)
    names = [f"uav{i}" for i in range(N)]
    followers = [FollowerNode(host, SWARM, name, sample_on_poll=lambda: FRAME)
                 for name in names]
    tally = Tally()
    with LeaderNode(sessions.node(port), SWARM, LeaderConfig(policy="whittle"),
                    on_delivery=tally.on_delivery) as leader:
        before = tally.wait("every follower delivered",
                            lambda counts: len(counts) == N)
        after = tally.wait(f"{ROUNDS} more deliveries each", lambda counts: min(
            counts[name] - before[name] for name in names) >= ROUNDS)
    for follower in followers:
        follower.close()
    window = [after[name] - before[name] for name in names]
    assert set(leader.followers) == set(names)
    assert max(window) <= 1.5 * min(window), sorted(window)
