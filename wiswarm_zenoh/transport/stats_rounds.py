"""The active leader's stats on Zenoh: the summary on ``leader/stats`` once a round,
and each follower's record while a subscriber matches its ``stats`` key (DESIGN.md's
contract: so a leader of a thousand followers that nobody watches one by one pays
nothing for them), spread evenly over the round (a record or two per poll, not all at
once while polling waits). ``every_record``: every follower's, for a reader in this
process (a live table, a stats file at exit: ``LeaderNode.latest``)."""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping

import zenoh

from wiswarm_zenoh.core import FollowerStats, Leader
from wiswarm_zenoh.transport.bridge import LeaderBridge
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.links import FollowerLink
from wiswarm_zenoh.transport.notify import notify
from wiswarm_zenoh.transport.telemetry import LeaderSummary, to_json

STATS_PERIOD = 0.4  # seconds: the contract asks for at least 2 Hz; stats cost a percentile


class StatsRounds:
    """Rounds of stats; ``due`` says when the next records are owed."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys, period: float,
                 started: float, policy: str, name: str, every_record: bool = False) -> None:
        self._period = period
        self._every_record = every_record
        self._started = started
        self._policy = policy
        self._name = name
        self._publisher = session.declare_publisher(keys.leader_stats,
                                                    encoding=zenoh.Encoding.APPLICATION_JSON)
        self.due = started
        self._mark = (started, 0)  # (time, polls) at the last summary
        self._owed: deque[str] = deque()  # followers this round's stats still owe
        self._round_start, self._round_size = started, 0
        self._records: list[FollowerStats] = []  # this round's so far
        self.latest: list[FollowerStats] = []  # the last whole round's
        self.summary = LeaderSummary([], 0.0, 0.0, policy, 0.0)

    @property
    def between_rounds(self) -> bool:
        return not self._owed

    def pause(self, now: float) -> None:
        """A standby publishes nothing (the active leader's stats are the swarm's)."""
        self.due = now + self._period
        self._owed.clear()

    def tick(self, now: float, leader: Leader, links: Mapping[str, FollowerLink],
             active: bool | None, bridge: LeaderBridge | None) -> None:
        """What is due by ``now``: nothing from a standby (the active leader's stats are
        the swarm's); the records due, and at a round's end the summary, handed to
        ``bridge`` too."""
        if not active:
            self.pause(now)
            return
        latest = self.latest
        self.publish(now, leader, links)
        if bridge is not None and self.latest is not latest:  # a round is done
            notify(lambda records: bridge.stats(records, now), self.latest)

    def publish(self, now: float, leader: Leader, links: Mapping[str, FollowerLink]) -> None:
        """Publish the records due by ``now`` (and the summary if the round is done)."""
        if not self._owed:
            self._owed = deque(f for f in leader.followers + leader.departed
                               if self._every_record or _listened(links, f))
            self._round_start, self._round_size, self._records = now, len(self._owed), []
        start, size = self._round_start, self._round_size
        owed_now = min(size, int(size * (now - start) / self._period) + 1)
        batch = []
        while self._owed and size - len(self._owed) < owed_now:
            follower = self._owed.popleft()
            link = links.get(follower)
            if link is not None:  # not gone since the round began
                batch.append(leader.stats(follower, now, link.errors))
        polls, epoch, in_flight = leader.polls, leader.epoch, leader.in_flight_limit
        for record in batch:
            if _listened(links, record.follower):
                links[record.follower].stats.put(to_json(record.as_dict()))
        self._records += batch
        if self._owed:
            self.due = start + self._period * (size - len(self._owed)) / size
            return
        self.due = start + self._period
        mark_time, mark_polls = self._mark
        rate = (polls - mark_polls) / (now - mark_time) if now > mark_time else 0.0
        present = {f: leader.mean_aoi(f, now) for f in leader.followers}
        summary = LeaderSummary.of(present, rate, self._policy, now - self._started,
                                   self._name, epoch, in_flight)
        self._publisher.put(to_json(summary.as_dict()))
        self.latest, self.summary = self._records, summary
        self._mark = (now, polls)

    def close(self) -> None:
        undeclare(self._publisher)


def _listened(links: Mapping[str, FollowerLink], follower: str) -> bool:
    link = links.get(follower)
    return link is not None and link.stats_listening
