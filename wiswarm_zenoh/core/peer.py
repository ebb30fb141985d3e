"""One follower as the leader knows it: its estimators, reassembly and counters, and the
only code that writes them.

Every write that moves a figure the policies read ends with ``_changed()``, which the
peer table installs (``peers.PeerTable.add``): the table keeps its columns in step by
itself, and no caller has to remember to.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from wiswarm_zenoh.core.aoi import AoITracker
from wiswarm_zenoh.core.clock import STAMP_SLACK, ClockOffsetEstimator
from wiswarm_zenoh.core.config import LeaderConfig
from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.estimators import ReliabilityEstimator, WeightEMA
from wiswarm_zenoh.core.events import Answering, Delivered, Event, Rejected, Silent, Stale, TimedOut
from wiswarm_zenoh.core.follower_stats import FollowerStats
from wiswarm_zenoh.core.fragments import Reassembler, verify_checksum
from wiswarm_zenoh.core.poll_timing import PollTiming, SwarmPollTimes
from wiswarm_zenoh.core.sources import SourcePace
from wiswarm_zenoh.core.wire import FragmentData, Reply, Want

LATE_KEPT = 8  # unanswered polls whose late replies still count (see Peer.timed_out)


def unwatched(peer: Peer) -> None:
    """A peer in no table (it left): nothing to keep in step."""


@dataclass(eq=False)
class Peer:
    """Estimators, reassembly and counters of one follower."""

    follower: str
    aoi: AoITracker
    reliability: ReliabilityEstimator
    weight: WeightEMA
    clock: ClockOffsetEstimator
    reassembler: Reassembler
    timing: PollTiming
    probe_interval: float  # the first back-off between probes of a silent follower
    probe_max: float  # the longest
    pace: SourcePace = field(default_factory=SourcePace)
    ack: tuple[int, int] | None = None
    idle_since: float = float("-inf")  # leader clock of its last "nothing new" answer
    probe_at: float = float("-inf")  # when a silent follower may be probed next
    probe_gap: float = 0.0  # the current back-off between probes (0: not silent)
    # (seq, sent at) of its latest polls that went unanswered: a reply to one of them,
    # late, still tells the link's pace (replies queue behind each other on a slow link)
    timed_out: deque[tuple[int, float]] = field(
        default_factory=lambda: deque(maxlen=LATE_KEPT))
    silent_since: float = 0.0  # when it last went silent
    left_at: float | None = None  # when its token went (None: present, or not told)
    want: Want = "next"
    polls: int = 0
    timeouts: int = 0
    errors: int = 0
    stale: int = 0
    on_change: Callable[[Peer], None] = field(default=unwatched, repr=False)

    @classmethod
    def new(cls, follower: str, config: LeaderConfig, now: float,
            swarm: SwarmPollTimes) -> Peer:
        """A follower just joined, judged by ``swarm``'s poll times until it answers."""
        return cls(
            follower=follower,
            aoi=AoITracker(now),
            reliability=ReliabilityEstimator(config.window, config.prior_p),
            weight=WeightEMA(config.alpha, config.initial_weight),
            clock=ClockOffsetEstimator(config.clock_samples),
            reassembler=Reassembler(config.max_fragments, config.max_update_bytes),
            timing=PollTiming(config.timeout, config.timeout_floor if config.adaptive_timeout
                              else config.timeout, swarm),
            probe_interval=config.probe_interval,
            probe_max=config.probe_max,
        )

    @property
    def silent(self) -> bool:
        return self.reliability.value <= 0.0

    # --- a poll's outcome ---

    def polled(self) -> None:
        self.polls += 1

    def answered(self, sent_at: float, reply: Reply, now: float) -> list[Event]:
        """A valid answer to its poll sent at ``sent_at``: the outcome, the clock sample,
        the fragment and, if that completes an update, its checks, AoI and delivery."""
        events: list[Event] = []
        if self.silent:
            events.append(Answering(self.follower, now - self.silent_since))
        self.timing.answered(max(now - sent_at, 1e-6))
        self._record(True, now)
        self.clock.add(sent_at, reply.received_at, reply.sent_at, now)
        events += self._take(reply.fragment, sent_at, reply.received_at, now)
        self._changed()
        return events

    def unanswered(self, poll_seq: int, sent_at: float, now: float) -> list[Event]:
        """Its poll ``poll_seq`` ended with no valid answer (a reply may still come after
        it, and teach how slow the link is: ``late_reply``)."""
        self.timed_out.append((poll_seq, sent_at))
        was_silent = self.silent
        self._record(False, now, early=sent_at < self.probe_at)
        self.timeouts += 1
        events: list[Event] = [TimedOut(self.follower, poll_seq)]
        if self.silent and not was_silent:
            self.silent_since = now
            ever = self.reliability.ever_answered
            events.append(Silent(self.follower, self.reliability.window if ever
                                 else self.timing.unanswered, ever))
        self._changed()
        return events

    def late_reply(self, reply: Reply, now: float) -> bool:
        """A valid reply to a poll that is not out: counted stale; if it answers one of
        its polls that went unanswered lately, that poll's time lengthens its timeout
        (its link is slower than measured). A follower silent since its first poll stays
        so until a probe is answered: a late reply proves nothing of who sent it."""
        self.stale += 1
        sent_at = self._late(reply.poll_seq) if reply.follower == self.follower else None
        if sent_at is None:
            return False
        self.timing.answered(now - sent_at)
        self._changed()
        return True

    def refused(self, first_for_poll: bool) -> None:
        """A reply refused as not its own (bad bytes, stamps no clock of it gives)."""
        self.errors += 1
        if first_for_poll:
            self.clock.refused()

    # --- what the application and the leader set ---

    def observe_urgency(self, v: float) -> float:
        """The application's urgency signal, through the weight's EMA; the new weight."""
        weight = self.weight.observe(v)
        self._changed()
        return weight

    def set_weight(self, weight: float) -> None:
        self.weight.value = weight
        self._changed()

    def share_reliability(self, estimator: ReliabilityEstimator) -> None:
        """From now on its p is ``estimator``'s, shared with the followers of its link."""
        self.reliability = estimator
        self._changed()

    def reliability_moved(self) -> None:
        """Its shared p was moved by a poll of another follower of its link."""
        self._changed()

    def restart(self) -> None:
        """The follower came back (new process): forget its transfer state and clock, and
        the polls it missed while it was gone; it is no longer silent, or is probed at
        once (its token's return says it is up: a back-off grown while it was dead would
        leave it unpolled for up to ``probe_max``)."""
        self.reliability.forget_outage()
        self.probe_gap, self.probe_at = 0.0, -math.inf
        self.reassembler.reset()
        self.clock.reset()
        self.timing.reset()
        self.pace.reset()
        self.timed_out.clear()
        self.ack = None
        self.want = "fresh"
        self._changed()

    def reachable(self) -> None:
        """It is up (its token came back within the leave's grace: a router failover, or
        a process restarted that fast): if silent, it is probed at once, not when a
        back-off grown while it was away ends. Its estimates stay."""
        if self.silent:
            self.probe_gap, self.probe_at = 0.0, -math.inf
            self._changed()

    def stats(self, now: float, refused_before: int = 0, present: bool = True) -> FollowerStats:
        """Its figures at ``now``: its age grows after it left, its mean, p95 and peak
        are those of its time present; ``refused_before`` counts among its errors."""
        until = now if present or self.left_at is None else min(now, self.left_at)
        return FollowerStats(
            follower=self.follower, aoi_s=self.aoi.age(now), mean_aoi_s=self.aoi.mean(until),
            p95_aoi_s=self.aoi.percentile(0.95, until), peak_aoi_s=self.aoi.peak(until),
            p_hat=self.reliability.value, weight=self.weight.value, polls=self.polls,
            deliveries=self.aoi.deliveries, timeouts=self.timeouts,
            errors=self.errors + refused_before,
            stale=self.stale, clock_offset_s=self.clock.offset, present=present,
        )

    # --- inside ---

    def _changed(self) -> None:
        self.on_change(self)

    def _record(self, answered: bool, now: float, early: bool = False) -> None:
        """Count a poll's outcome; a silent follower's next probe backs off exponentially,
        once per back-off: a probe sent before it was due (``early``: every follower was
        silent, so it was polled anyway) does not grow it. Those end at once while no
        queryable is there: a swarm's followers restarting together backed off to
        ``probe_max`` within milliseconds, and the last to come back waited that long."""
        if not answered:
            self.timing.timed_out(silent=self.silent)
        self.reliability.record(answered)
        if self.reliability.value > 0.0:
            self.probe_gap, self.probe_at = 0.0, -math.inf
            return
        if early:
            return
        self.probe_gap = self.probe_interval if self.probe_gap == 0.0 \
            else min(2 * self.probe_gap, self.probe_max)
        self.probe_at = now + self.probe_gap

    def _late(self, poll_seq: int) -> float | None:
        """When its poll ``poll_seq`` was sent, if that poll went unanswered lately (and
        is then forgotten: one late reply teaches once)."""
        for entry in self.timed_out:
            if entry[0] == poll_seq:
                self.timed_out.remove(entry)
                return entry[1]
        return None

    def _take(self, frag: FragmentData | None, sent_at: float, received_at: float,
              now: float) -> list[Event]:
        """An answer's fragment: into reassembly (an update's first: its source's phase,
        ``SourcePace.reached``); an update it completes is delivered if
        its time-stamp can be true (not ahead of the reply's arrival by more than the
        clock estimate's error: the poll's round trip, and some slack), its checksum
        holds and it is fresher than any before (its time-stamp on the leader's clock
        as estimated now: a follower restarting later changes nothing)."""
        if frag is None:
            self.idle_since = now
            self.pace.empty(now)
            return []
        try:
            whole = self.reassembler.add(frag)
        except WireError as exc:
            return self._ask_afresh(str(exc))
        self.ack, self.want = (frag.update_seq, frag.index), "next"
        if frag.index == 0 and self.pace.skips:
            self.pace.reached(sent_at, received_at, frag.generated_at, frag.count == 1)
        if whole is None:
            return []
        generated_at = self.clock.to_leader(frag.generated_at)
        ahead = generated_at - now
        if ahead > now - sent_at + STAMP_SLACK:
            self.errors += 1
            return [Rejected(self.follower, f"update stamped {ahead:.3f} s in the future")]
        try:
            verify_checksum(whole, frag)
        except WireError as exc:
            return self._ask_afresh(str(exc))
        self.pace.taken(frag.update_seq, frag.generated_at, generated_at)
        generated_at = min(generated_at, now)  # ahead within the tolerance: now
        if not self.aoi.deliver(generated_at, now):
            self.stale += 1
            return [Stale(self.follower, "update older than the freshest delivered")]
        return [Delivered(self.follower, whole, generated_at, now, frag.update_seq)]

    def _ask_afresh(self, reason: str) -> list[Event]:
        """A fragment or an update that cannot be used: its next poll asks for a fresh one."""
        self.errors += 1
        self.ack, self.want = None, "fresh"
        return [Rejected(self.follower, reason)]
