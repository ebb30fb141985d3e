"""Several leaders for one swarm: the oldest polls, the others stand by and take over
with its weights and control, at a higher epoch. Real sessions on loopback."""

from __future__ import annotations

import threading

import zenoh

from wiswarm_zenoh.core import Waypoint
from wiswarm_zenoh.transport import FollowerNode, LeaderNode

from .helpers import WAIT, Recorder, Samples, Sessions

SWARM = "standby"
OLD, YOUNG = 1_000_000, 2_000_000  # start times (us): the older leads


class Obeyed:
    """A follower's control callback, waitable."""

    def __init__(self) -> None:
        self.entries: list[list[Waypoint]] = []
        self.cond = threading.Condition()

    def __call__(self, entry: list[Waypoint]) -> None:
        with self.cond:
            self.entries.append(entry)
            self.cond.notify_all()

    def wait_for(self, entry: list[Waypoint]) -> None:
        with self.cond:
            assert self.cond.wait_for(lambda: entry in self.entries, WAIT), entry


def _followers(sessions: Sessions, port: int, obeyed: Obeyed) -> list[FollowerNode]:
    return [FollowerNode(sessions.node(port), SWARM, fid, sample_on_poll=lambda: b"frame",
                         on_control=obeyed if fid == "f1" else None)
            for fid in ("f1", "f2")]


def test_the_oldest_leader_polls_and_a_standby_takes_over_with_its_state(
    sessions: Sessions, router: zenoh.Session, port: int
) -> None:
    obeyed = Obeyed()
    _followers(sessions, port, obeyed)
    first, second = Recorder(), Recorder()
    stats = Samples(sessions.node(port), f"wiswarm/{SWARM}/leader/stats")
    # Clients of the router, as deployed leaders are: tokens then take one way, not
    # also a peer link that comes up later (whose set-up a standby could see as the
    # active leader's token going for a moment)
    old_session = sessions.node(port, "client")
    old = LeaderNode(old_session, SWARM, epoch=OLD, name="old", **first.callbacks())
    # The young one starts once the old one polls: its token has reached the router
    # before its polls did (one session, one link). Two leaders started within the same
    # millisecond may both poll for a moment, until each has heard the other's token.
    first.wait("the old leader delivers", lambda r: len(r.deliveries) >= 1)
    young = LeaderNode(sessions.node(port, "client"), SWARM, epoch=YOUNG, name="young",
                       every_record=True, **second.callbacks())
    try:
        first.wait("the old leader delivers", lambda r: len(r.deliveries) >= 50)
        assert old.active and not young.active
        assert not second.deliveries  # a standby polls nobody
        old.set_control("f1", [(1.0, 2.0, 3.0, 4.0)])
        old.observe_urgency("f2", 9.0)
        obeyed.wait_for([(1.0, 2.0, 3.0, 4.0)])
        stats.wait("stats of the old leader", lambda s: any(
            r["leader"] == "old" and r["epoch"] == old.epoch for r in s.stats(stats_key())))
        weights = Samples(sessions.node(port), f"wiswarm/{SWARM}/f2/stats")
        weights.wait("f2's new weight published", lambda s: any(
            r["weight"] > 2.5 for r in s.stats(f"wiswarm/{SWARM}/f2/stats")))
        old.close()
        old_session.close()  # its token goes: the standby takes over
        second.wait("the young leader delivers", lambda r: len(r.deliveries) >= 50)
        assert young.active and young.epoch > OLD  # above the epoch it took over from
        stats.wait("stats of the young leader", lambda s: any(
            r["leader"] == "young" and r["epoch"] == young.epoch for r in s.stats(stats_key())))
        young.set_control("f1", [(6.0, 6.0, 6.0, 6.0)])
        obeyed.wait_for([(6.0, 6.0, 6.0, 6.0)])
        with obeyed.cond:  # the young leader's control, sent again, is all f1 obeys now
            since = obeyed.entries.index([(6.0, 6.0, 6.0, 6.0)])
            assert obeyed.cond.wait_for(lambda: len(obeyed.entries) >= since + 4, WAIT)
            assert all(e == [(6.0, 6.0, 6.0, 6.0)] for e in obeyed.entries[since:])
        weights = {r.follower: r.weight for r in young.latest}
        assert weights["f2"] > 2.5  # 0.8 * 1 + 0.2 * 9, as the old leader had it
    finally:
        young.close()


def stats_key() -> str:
    return f"wiswarm/{SWARM}/leader/stats"


def test_a_younger_active_leader_steps_down_for_an_older_one_and_it_rises_above(
    sessions: Sessions, router: zenoh.Session, port: int
) -> None:
    """As when a partition heals: each side had an active leader; the younger yields,
    and the older takes an epoch above the younger's so that followers follow it."""
    _followers(sessions, port, Obeyed())
    second, first = Recorder(), Recorder()
    with LeaderNode(sessions.node(port), SWARM, epoch=YOUNG, name="young",
                    **second.callbacks()) as young:
        second.wait("the young leader delivers", lambda r: len(r.deliveries) >= 20)
        assert young.active
        with LeaderNode(sessions.node(port), SWARM, epoch=OLD, name="old",
                        **first.callbacks()) as old:
            first.wait("the old leader delivers", lambda r: len(r.deliveries) >= 20)
            assert old.active and not young.active
            assert old.epoch > young.epoch  # the followers' main poller: its control counts
