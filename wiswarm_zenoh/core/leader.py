"""The leader's state machine: whom to poll, and what a reply or a timeout means."""

from __future__ import annotations

import math
import random
from collections import deque
from collections.abc import Mapping, Sequence

from wiswarm_zenoh.core.config import LeaderConfig
from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.events import Answering, Event, Rejected, Silent, Stale, TimedOut, drain
from wiswarm_zenoh.core.fast_path import quick_choice
from wiswarm_zenoh.core.in_flight import InFlightTuner
from wiswarm_zenoh.core.messages import check_epoch
from wiswarm_zenoh.core.peers import FollowerStats, Peer, PeerTable
from wiswarm_zenoh.core.plausibility import implausible
from wiswarm_zenoh.core.policies import IndexPolicy, make_policy
from wiswarm_zenoh.core.poll_records import Pick, PollLife, PollRequest, Stage
from wiswarm_zenoh.core.reply_work import settle_update, take_fragment
from wiswarm_zenoh.core.scheduling import choose, pick_after
from wiswarm_zenoh.core.site_links import SiteLinks
from wiswarm_zenoh.core.wire import (
    Poll,
    Reply,
    Waypoint,
    decode_reply,
    encode_poll,
    pack_entries,
    validate_waypoints,
)

__all__ = ["FollowerStats", "Leader", "PollRequest", "drain"]

SLOT_EMA = 0.9  # smoothing of the mean poll duration, the "slot" of slotted policies
END_GRACE = 0.002  # seconds a poll whose request is over still waits for its reply


class Leader:
    """Sans-I/O leader (paper, Section II-D): one poll in flight at a time (or
    ``config.in_flight``, each to another follower, where the link is not shared; or as
    many as ``in_flight.InFlightTuner`` finds worth it).

    The shell feeds input and pulls output, nothing else (aioquic's shape). Input:
    membership (``add_/remove_/forget_follower``), ``receive_reply(follower, data, now)``
    for every reply, ``handle_timer(now)`` at ``get_timer()``. Output: ``next_poll(now)``
    until None, then ``next_event()`` until None. Bad bytes never raise: they come back
    as ``Rejected`` events and are counted against the follower.

    A valid reply ends its poll at once; the rest of taking it waits in the poll's
    record (``poll_records``), done in arrival order by ``next_event`` after the shell
    sent the next poll, or by ``next_poll`` when choosing needs it first. When
    ``next_event`` has nothing left while one poll is out, the core picks whom to poll
    after it (``scheduling.pick_after``, ages at the reply's expected time); if the reply
    comes as expected and the polled follower's new index (clock offset as before it)
    does not beat that pick, ``next_poll`` sends it at once (``fast_polls``).
    """

    def __init__(self, config: LeaderConfig | None = None, rng: random.Random | None = None,
                 epoch: int = 0) -> None:
        check_epoch(epoch)
        self.config = config or LeaderConfig()
        self.epoch = epoch  # in every poll and control: followers tell leaders apart by it
        self.policy = make_policy(self.config.policy, rng)
        self.table = PeerTable(self.config.weight_floor, self.config.price_by_time,
                               self.config.pace_sources)
        self._pacing = self.config.pace_sources and isinstance(self.policy, IndexPolicy)
        self.unknown_replies = 0
        self.polls = 0
        self.fast_polls = 0  # polls sent on a pick made while the poll before was out
        self.slot = 0.01  # mean poll duration in seconds, refined as polls complete
        self._poll_seq = 0
        self._control_seq = 0
        self._waypoints: dict[str, list[Waypoint]] = {}
        self._packed_control: bytes | None = None  # cache of the packed entries
        self._flights: dict[str, PollLife] = {}  # the polls out (stage SENT), by follower
        self._waiting: deque[PollLife] = deque()  # answered polls whose work waits
        self._events: deque[Event] = deque()
        self._pick: Pick | None = None
        self._picked_for = 0  # the poll a pick was last tried for
        self._departed: dict[str, Peer] = {}  # left, not forgotten: ageing in ``stats``
        self.site_links = SiteLinks()
        self.tuner = InFlightTuner() if self.config.in_flight == "auto" else None

    @property
    def followers(self) -> list[str]:
        """The followers it polls now, in the order they were added."""
        return list(self.table.ids)

    @property
    def departed(self) -> list[str]:
        """Followers that left and are not forgotten: polled no more, their age growing."""
        return list(self._departed)

    @property
    def polls_allowed(self) -> int:
        """Polls it keeps out at most now: ``config.in_flight``, or the tuner's (a trial's
        K during a trial)."""
        tuner = self.tuner
        return self.in_flight_limit if tuner is None else tuner.current

    @property
    def in_flight_limit(self) -> int:
        """The polls it keeps out, trials aside: ``config.in_flight``, or what the tuner
        found."""
        if self.tuner is not None:
            return self.tuner.limit
        assert self.config.in_flight != "auto"
        return self.config.in_flight

    @property
    def in_flight(self) -> str | None:
        """The follower polled, while a poll is out (the earliest, when several are)."""
        return next(iter(self._flights), None)

    # --- input ---

    def add_follower(self, follower: str, now: float, link: str | None = None) -> None:
        """A follower joined, or rejoined after a restart (its transfer state is reset;
        a reply it gave before is taken first, as things were then). One that left and
        comes back is taken up where it was: its age is what its last delivery makes it,
        not a fresh start. Followers given one ``link`` (a site) share its p."""
        if not follower:
            raise ValueError("follower id must be a non-empty string")
        self._advance(settle=True)
        self._pick = None
        peer = self.table.peers.get(follower)
        if peer is not None:
            peer.restart()
            return
        back = self._departed.pop(follower, None)
        if back is not None:
            back.restart()
            back.left_at = None
        peer = back or Peer.new(self.config, now, self.table.poll_times)
        if link is not None:
            self.site_links.attach(follower, peer, link)
        self.table.add(follower, peer)

    def remove_follower(self, follower: str, now: float | None = None) -> None:
        """A follower left (its liveliness token went) at ``now``: it is polled no more,
        its poll and replies are dropped. Its record stays, ageing (``stats``,
        ``departed``), as nothing fresh comes from it, until ``forget_follower`` or its
        return; its mean and p95 AoI stay those of its time present."""
        peer = self.table.peers.get(follower)
        if peer is None:
            return
        peer.left_at = now
        self._flights.pop(follower, None)
        self._waiting = deque(life for life in self._waiting
                              if life.request.follower != follower)
        self._pick = None
        self.table.remove(follower)
        self.site_links.detach(follower)
        self._departed[follower] = peer
        if self._waypoints.pop(follower, None) is not None:
            self._packed_control = None

    def forget_follower(self, follower: str) -> None:
        """Drop the record of a follower that left (the shell decides how long to keep
        showing its age)."""
        self._departed.pop(follower, None)

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        """The application's latest control information for one follower."""
        self._peer(follower)
        self._waypoints[follower] = validate_waypoints(waypoints)
        self._packed_control = None

    def take_over(self, epoch: int, weights: Mapping[str, float],
                  control: Mapping[str, Sequence[Sequence[float]]]) -> None:
        """Become the active leader as ``epoch`` (larger than the leader's it takes over
        from), with that leader's weights and last control, not from zero. Followers it
        does not know yet are skipped: their tokens bring them in."""
        check_epoch(epoch)
        self.epoch = epoch
        for follower, weight in weights.items():
            peer = self.table.peers.get(follower)
            if peer is not None and math.isfinite(weight) and weight >= 0.0:
                peer.weight.value = weight
                self.table.sync(follower)
        for follower, waypoints in control.items():
            if follower in self.table.peers:
                self._waypoints[follower] = validate_waypoints(waypoints)
        self._packed_control = None
        self._pick = None

    def observe_urgency(self, follower: str, v: float) -> float:
        """Feed the application's urgency signal into the weight EMA; returns the weight."""
        weight = self._peer(follower).weight.observe(v)
        self.table.sync(follower)
        self._pick = None
        return weight

    def receive_reply(self, follower: str, data: bytes, now: float) -> None:
        """One reply from ``follower`` (the key it came from), whatever it holds."""
        peer = self.table.peers.get(follower)
        if peer is None:  # one that just left may still answer: that is no bad input
            if follower not in self._departed:
                self.unknown_replies += 1
                self._events.append(Stale(follower, "reply from a follower that is not a member"))
            return
        try:
            reply = decode_reply(data, follower)
        except WireError as exc:
            self._reject(peer, follower, str(exc))
            return
        life = self._flights.get(follower)
        if life is None or reply.poll_seq != life.request.poll_seq:
            self._not_in_flight(peer, follower, reply, now)
            return
        if reply.follower != follower:
            self._reject(peer, follower, f"reply claims to come from {reply.follower!r}")
            return
        reason = implausible(life.request, peer, reply, now)
        if reason is not None:  # not this follower's answer: the poll waits for the real one
            self._reject(peer, follower, reason)
            return
        del self._flights[follower]
        life.stage, life.reply, life.answered_at = Stage.ANSWERED, reply, now
        self._waiting.append(life)

    def handle_timer(self, now: float) -> None:
        """Every poll out whose deadline has passed is unanswered."""
        expired = [life for life in self._flights.values() if now >= life.request.deadline]
        if not expired:
            return
        self._advance(settle=True)  # what came before them is reported before them
        for life in sorted(expired, key=lambda life: life.request.deadline):
            self._unanswered(life, now)

    def receive_end(self, follower: str, poll_seq: int, now: float) -> None:
        """No more replies can come to poll ``poll_seq`` of ``follower``: the shell's
        request is over (Zenoh's get: no queryable matched, or every replier sent its
        last). If no valid reply was taken, the poll is unanswered within ``END_GRACE``,
        not at its deadline, and the channel is free for the next; a reply refused
        meanwhile kept it open only while the genuine answer could still come. (The
        grace: a reply and the get's end may come over two paths, a peer's own link
        and the router's, and the end first.)"""
        life = self._flights.get(follower)
        if life is None or life.request.poll_seq != poll_seq:
            return  # answered, or timed out before (a late reply may still be on its way)
        life.request.deadline = min(life.request.deadline, now + END_GRACE)

    # --- output ---

    def next_poll(self, now: float) -> PollRequest | None:
        """The poll to send now, put in flight; None while ``config.in_flight`` are out,
        nobody is left to poll, or no poll can find anything new before ``get_timer()``
        (every source paced and none due, no probe due: ``sources``)."""
        out = self._flights
        if len(out) >= self.polls_allowed or len(out) >= len(self.table.ids):
            return None
        if self._waits_for_sources(now):
            return None
        choice = self._quick_choice(now) if not out else None
        if choice is None:
            self._advance(settle=False)
            choice = choose(self.table, self.policy, self.slot, now,
                            {self.table.index(f) for f in out})
        else:
            self.fast_polls += 1
        return self._start_poll(choice, now)

    def next_event(self) -> Event | None:
        """What happened, oldest first, doing the work that waited; None when nothing is
        left (and then, with a poll out, the pick for after it is made)."""
        if not self._events and self._waiting:
            self._advance(settle=True)
        if self._events:
            return self._events.popleft()
        life = next(iter(self._flights.values())) if len(self._flights) == 1 else None
        if life is not None and self.polls_allowed == 1 \
                and self._picked_for != life.request.poll_seq:
            self._picked_for = life.request.poll_seq
            self._pick = pick_after(self.table, self.policy, self.slot, life.request.poll_seq,
                                    self.table.index(life.request.follower),
                                    life.request.sent_at + self.slot)
        return None

    def get_timer(self) -> float | None:
        """When ``handle_timer`` is due: the earliest deadline of the polls out, or,
        while another poll may go out, when the first source or probe is due."""
        flights = self._flights
        wake = math.inf
        if self._waits_for_sources(-math.inf) \
                and len(flights) < min(self.polls_allowed, len(self.table.ids)):
            wake = self.table.wake_at()
        if flights:
            wake = min(wake, min(life.request.deadline for life in flights.values()))
        return wake if math.isfinite(wake) else None

    def stats(self, follower: str, now: float) -> FollowerStats:
        """One follower's figures, every reply so far taken (one that left: ageing)."""
        self._advance(settle=True)
        if follower in self._departed:
            return self._departed[follower].stats(follower, now, present=False)
        return self._peer(follower).stats(follower, now)

    # --- inside ---

    def _waits_for_sources(self, now: float) -> bool:
        """No poll can find anything new before ``table.wake_at()`` (after ``now``):
        every live follower's source is paced and not due, no probe is due. (A swarm of
        silent followers only is polled on, as without pacing: one that came back is
        found at once.)"""
        table = self.table
        return self._pacing and table.silent < len(table) and table.wake_at() > now

    def _peer(self, follower: str) -> Peer:
        try:
            return self.table.peers[follower]
        except KeyError:
            raise ValueError(f"unknown follower {follower!r}") from None

    def _reject(self, peer: Peer, follower: str, reason: str) -> None:
        peer.errors += 1
        self._events.append(Rejected(follower, reason))

    def _unanswered(self, life: PollLife, now: float) -> None:
        """The poll of ``life`` ends with no valid answer (a reply may still come after
        it, and teach how slow the link is)."""
        request, peer = life.request, life.peer
        del self._flights[request.follower]
        peer.timed_out.append((request.poll_seq, request.sent_at))
        was_silent = peer.silent
        self._complete(request, peer, answered=False, now=now)
        if self.tuner is not None:
            self.tuner.completed(False, now, len(self.table.ids))
        peer.timeouts += 1
        self.table.sync(request.follower)
        self._events.append(TimedOut(request.follower, request.poll_seq))
        if peer.silent and not was_silent:
            peer.silent_since = now
            ever = peer.reliability.ever_answered
            self._events.append(Silent(request.follower,
                                       self.config.window if ever else peer.timing.unanswered,
                                       ever))

    def _not_in_flight(self, peer: Peer, follower: str, reply: Reply, now: float) -> None:
        """A valid reply to a poll that is not out: late (it lengthens the follower's
        timeout: its link is slower than measured) or stale."""
        peer.stale += 1
        sent_at = peer.late(reply.poll_seq) if reply.follower == follower else None
        if sent_at is None:
            self._events.append(Stale(follower, f"reply to poll {reply.poll_seq}, not one out"))
            return
        # A follower silent since its first poll stays so until a probe is answered: a
        # late reply proves nothing of who sent it (no clock of it is known to judge by).
        peer.timing.answered(now - sent_at)
        self.table.sync(follower)

    def _quick_choice(self, now: float) -> int | None:
        """The pick made while the last poll was out, if it still holds (``fast_path``)."""
        pick, self._pick = self._pick, None
        if pick is None or len(self._waiting) != 1:
            return None  # nothing picked, or more work waiting
        return quick_choice(pick, self._waiting[0], self.table, self.site_links, self.slot,
                            self._pacing, now)

    def _start_poll(self, choice: int, now: float) -> PollRequest:
        """Put a poll of the follower at ``choice`` in the table in flight."""
        follower = self.table.ids[choice]
        peer = self.table.peers[follower]
        self._poll_seq += 1
        self._control_seq += 1
        self.polls += 1
        peer.polls += 1
        if self._packed_control is None:
            self._packed_control = pack_entries(self._waypoints)
        poll = Poll(self._poll_seq, now, peer.ack, peer.want, self.epoch)
        request = PollRequest(
            follower, self._poll_seq, encode_poll(poll), now + peer.timing.timeout, now,
            self._control_seq, self._packed_control, self.epoch,
        )
        self._flights[follower] = PollLife(request, peer)
        return request

    def _advance(self, settle: bool) -> None:
        """The work that waited, in arrival order: each answer's outcome, clock sample
        and fragment; with ``settle``, each whole update's checksum, AoI and delivery."""
        if not self._waiting:
            return
        left: deque[PollLife] = deque()
        for life in self._waiting:
            if life.stage is Stage.ANSWERED:
                self._take_answer(life)
            if life.stage is Stage.UNSETTLED:
                if settle:
                    self._events.extend(settle_update(life, self.table))
                else:
                    left.append(life)
        self._waiting = left

    def _take_answer(self, life: PollLife) -> None:
        """A valid answer's effects: the poll's outcome, the clock, the fragment."""
        request, peer, reply, now = life.request, life.peer, life.reply, life.answered_at
        assert reply is not None
        if peer.silent:
            self._events.append(Answering(request.follower, now - peer.silent_since))
        self._complete(request, peer, answered=True, now=now)
        peer.clock.add(request.sent_at, reply.received_at, reply.sent_at, now)
        self._events.extend(take_fragment(life))
        if self.tuner is not None:  # the answers that carry something are the throughput
            self.tuner.completed(reply.fragment is not None, now, len(self.table.ids))
        self.table.sync(request.follower)

    def _complete(self, request: PollRequest, peer: Peer, answered: bool, now: float) -> None:
        """The poll ``request`` is over (the caller syncs the policy columns)."""
        duration = max(now - request.sent_at, 1e-6)
        self.slot = SLOT_EMA * self.slot + (1.0 - SLOT_EMA) * duration
        if answered:
            peer.timing.answered(duration)
        cfg = self.config
        before = peer.reliability.value
        peer.record_poll(answered, now, cfg.probe_interval, cfg.probe_max)
        if peer.reliability.value != before:
            self._events.extend(self.site_links.shared_change(
                request.follower, before, self.table, cfg.window, now))

