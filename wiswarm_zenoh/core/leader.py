"""The leader's state machine: whom to poll, and what a reply or a timeout means."""

from __future__ import annotations

import math
import random
from collections import deque
from collections.abc import Mapping, Sequence

from wiswarm_zenoh.core.config import LeaderConfig
from wiswarm_zenoh.core.control_schedule import ControlSchedule
from wiswarm_zenoh.core.early_answers import answer_decides
from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.events import Event, Rejected, Stale, drain
from wiswarm_zenoh.core.in_flight import InFlightTuner
from wiswarm_zenoh.core.member_book import MemberBook, check_weight
from wiswarm_zenoh.core.messages import check_epoch
from wiswarm_zenoh.core.peers import FollowerStats, Peer, PeerTable
from wiswarm_zenoh.core.plausibility import implausible
from wiswarm_zenoh.core.policies import IndexPolicy, make_policy
from wiswarm_zenoh.core.poll_hold import PollHold
from wiswarm_zenoh.core.poll_records import Flight, Pick, PollRequest
from wiswarm_zenoh.core.scheduling import choose, pick_after, still_holds
from wiswarm_zenoh.core.site_links import SiteLinks
from wiswarm_zenoh.core.wire import Poll, decode_reply, encode_poll, validate_waypoints

__all__ = ["FollowerStats", "Leader", "PollRequest", "drain"]

SLOT_EMA = 0.9  # smoothing of the mean poll duration, the "slot" of slotted policies
END_GRACE = 0.002  # seconds a poll whose request is over still waits for its reply


class Leader:
    """Sans-I/O leader (paper, Section II-D): one poll in flight at a time (or
    ``config.in_flight``, each to another follower, where the link is not shared; or as
    many as ``in_flight.InFlightTuner`` finds worth it).

    The shell feeds input and pulls output, nothing else (aioquic's shape). Input:
    membership (``add_/remove_/forget_follower``, ``follower_reachable``: ``member_book``),
    the application's control and weights, ``receive_reply`` for every reply,
    ``receive_end`` when a request can bring no more, ``handle_timer(now)`` at
    ``get_timer()``; each does all its work at once. Output:
    ``next_poll(now)`` until None (each poll, with the control broadcast when it is due:
    ``config.control_period``), ``next_event()`` until None (it only pops). Bad bytes
    never raise: they come back as ``Rejected`` events, counted against the follower.

    With one poll out, the ``next_poll`` call that finds no room picks whom to poll
    after it (``scheduling.pick_after``: ages at the reply's expected time); if the
    reply comes as expected and nothing else moved, the next ``next_poll`` weighs only
    the polled follower's new index against that pick (``scheduling.still_holds``,
    ``fast_polls``) instead of a pass over every follower; where the reply alone
    decides that, before the reply is judged (``poll_on_answer``, ``early_polls``).
    """

    def __init__(self, config: LeaderConfig | None = None, rng: random.Random | None = None,
                 epoch: int = 0) -> None:
        check_epoch(epoch)
        self.config = config or LeaderConfig()
        self.epoch = epoch  # in every poll and control: followers tell leaders apart by it
        self.policy = make_policy(self.config.policy, rng)
        self.table = PeerTable(self.config.weight_floor, self.config.price_by_time,
                               self.config.pace_sources)
        # An index policy's pick can be made ahead (``scheduling.pick_after``); None: not.
        self._indexed = self.policy if isinstance(self.policy, IndexPolicy) else None
        self._pacing = self.config.pace_sources and self._indexed is not None
        self.unknown_replies = 0
        self.polls = 0
        self.fast_polls = 0  # polls sent on a pick made while the poll before was out
        self.early_polls = 0  # of them, those sent before that reply was judged
        self.slot = 0.01  # mean poll duration in seconds, refined as polls complete
        self._poll_seq = 0
        self._control = ControlSchedule(self.config.control_period)
        self._flights: dict[str, Flight] = {}  # the polls out, by follower
        self._events: deque[Event] = deque()
        self._pick: Pick | None = None
        self._picked_for = 0  # the poll a pick was last tried for
        self._answered_seq = 0  # the poll answered last
        self._hold = PollHold()  # a lone poll held for a phased source's next update
        self.site_links = SiteLinks()
        self.members = MemberBook(self.config, self.table, self.site_links)
        in_flight = self.config.in_flight
        self.tuner = InFlightTuner() if in_flight == "auto" else None
        self._fixed_in_flight = 1 if in_flight == "auto" else in_flight

    @property
    def followers(self) -> list[str]:
        """The followers it polls now, in the order they were added."""
        return list(self.table.ids)

    @property
    def departed(self) -> list[str]:
        """Followers that left and are not forgotten: polled no more, their age growing."""
        return list(self.members.departed)

    @property
    def polls_allowed(self) -> int:
        """Polls it keeps out at most now: ``config.in_flight``, or the tuner's (a trial's
        K during a trial)."""
        tuner = self.tuner
        return self._fixed_in_flight if tuner is None else tuner.current

    @property
    def in_flight_limit(self) -> int:
        """The polls it keeps out, trials aside: ``config.in_flight`` or the tuner's."""
        return self._fixed_in_flight if self.tuner is None else self.tuner.limit

    @property
    def in_flight(self) -> str | None:
        """The follower polled, while a poll is out (the earliest, when several are)."""
        return next(iter(self._flights), None)

    def awaits(self, follower: str, poll_seq: int) -> bool:
        """Poll ``poll_seq`` of ``follower`` is out: neither answered nor given up."""
        flight = self._flights.get(follower)
        return flight is not None and flight.request.poll_seq == poll_seq

    # --- input ---

    def add_follower(self, follower: str, now: float, link: str | None = None) -> None:
        """A follower joined, or rejoined after a restart (transfer state reset). One
        that left and comes back is taken up where it was (its age, not a fresh start;
        its p without the polls it missed; polled as its index says, not after a
        probe's back-off). Followers given one ``link`` (a site) share its p. A weight
        preset for it (``preset_weight``) is its weight again at each join."""
        if not follower:
            raise ValueError("follower id must be a non-empty string")
        self._pick = None
        self._control.join(follower, link)  # the newcomer needs the control now
        self.members.join(follower, now, link)

    def remove_follower(self, follower: str, now: float | None = None) -> None:
        """A follower left (its token went) at ``now``: polled no more, its poll and
        replies dropped. Its record stays, ageing (``stats``, ``departed``), until
        ``forget_follower`` or its return; its mean and p95 AoI are its time present's."""
        if not self.members.leave(follower, now):
            return
        self._flights.pop(follower, None)
        self._pick = None
        self._control.drop(follower)

    def follower_reachable(self, follower: str) -> None:
        """Its token came back within the shell's grace: if silent, probed now."""
        self._pick = None
        if (peer := self.table.peers.get(follower)) is not None:
            peer.reachable()

    def forget_follower(self, follower: str) -> None:
        """Drop the record of a follower that left (the shell says when)."""
        self.members.departed.pop(follower, None)

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        """The application's latest control information for one follower."""
        self.members.peer(follower)
        self._control.set(follower, waypoints)

    def rise_above(self, heard: int, now: float, weights: Mapping[str, float] | None = None,
                   control: Mapping[str, Sequence[Sequence[float]]] | None = None) -> int:
        """Become (or stay) the active leader, with an epoch (returned) above ``heard``
        (the largest heard) and ``now`` in µs (above any leader active before, even one
        never heard), and the ``weights`` and ``control`` it takes over (``take_over``)."""
        epoch = max(self.epoch, heard + 1, int(now * 1e6))
        self.take_over(epoch, weights or {}, control or {})
        return epoch

    def take_over(self, epoch: int, weights: Mapping[str, float],
                  control: Mapping[str, Sequence[Sequence[float]]]) -> None:
        """Become the active leader as ``epoch`` (larger than the leader's it takes over
        from), with that leader's weights and last control, not from zero. Followers it
        does not know yet are skipped: their tokens bring them in."""
        check_epoch(epoch)
        self.epoch = epoch
        self.members.take_weights(weights)
        for follower, waypoints in control.items():
            if follower in self.table.peers:
                self._control.waypoints[follower] = validate_waypoints(waypoints)
        self._control.changed()  # the followers learn the new epoch at once
        self._pick = None

    def observe_urgency(self, follower: str, v: float) -> float:
        """Feed the application's urgency signal into the weight EMA; returns the weight."""
        return self.members.peer(follower).observe_urgency(v)

    def set_weight(self, follower: str, weight: float) -> None:
        """An operator's weight for ``follower``, as is (the urgency EMA goes on from
        it); ValueError for a follower not polled or a weight that is not >= 0."""
        self.members.peer(follower).set_weight(check_weight(weight))
        self._pick = None  # a pick made ahead weighed the old weight

    def preset_weight(self, follower: str, weight: float) -> None:
        """An operator's weight for ``follower``, a member yet or not: now, and at each
        join (ValueError if not >= 0; ``members.never_joined``: those not seen yet)."""
        self.members.preset(follower, weight)
        self._pick = None

    def receive_reply(self, follower: str, data: object, now: float) -> None:
        """One reply from ``follower`` (the key it came from), whatever it holds (not
        bytes at all: refused, as garbage is)."""
        peer = self.table.peers.get(follower)
        if peer is None:  # one that just left may still answer: that is no bad input
            if follower not in self.members.departed:
                self.unknown_replies += 1
                self._events.append(Stale(follower, "reply from a follower that is not a member"))
            return
        try:
            reply = decode_reply(data, follower)
        except WireError as exc:
            self._reject(peer, follower, str(exc))
            return
        flight = self._flights.get(follower)
        if flight is None or reply.poll_seq != flight.request.poll_seq:
            if not peer.late_reply(reply, now):
                self._events.append(Stale(follower,
                                          f"reply to poll {reply.poll_seq}, not one out"))
            return
        if reply.follower != follower:
            self._reject(peer, follower, f"reply claims to come from {reply.follower!r}")
            return
        request = flight.request
        refusal = implausible(peer.clock, request.sent_at, reply, now, flight.refused)
        if refusal is not None:  # not this follower's answer: the poll waits for the real one
            reason, by_clock = refusal
            peer.refused(first_for_poll=by_clock and not flight.refused)
            flight.refused |= by_clock
            self._events.append(Rejected(follower, reason))
            return
        del self._flights[follower]
        self._answered_seq = request.poll_seq
        before = peer.reliability.value
        self._complete(request, now, peer, before, peer.answered(request.sent_at, reply, now))
        if self.tuner is not None:  # the answers that carry something are the throughput
            self.tuner.completed(reply.fragment is not None, now, len(self.table.ids))

    def poll_on_answer(self, follower: str, data: object, now: float) -> PollRequest | None:
        """The next poll, put in flight before ``data``, a reply of ``follower``, is
        judged (``receive_reply`` with the same ``data`` comes next, as always), where
        the reply alone decides it (``early_answers``): one poll out, sources taken as
        always fresh, not a site's follower. None: judge first, then ``next_poll``."""
        pick, flight, table = self._pick, self._flights.get(follower), self.table
        if pick is None or flight is None or len(self._flights) != 1 or self.tuner is not None \
                or self._fixed_in_flight != 1 or table.unfresh or table.known_intervals \
                or follower in self.site_links.link_of or flight.request.poll_seq != \
                pick.poll_seq or not answer_decides(pick, flight, table, data, now):
            return None
        self._pick = None
        self.fast_polls += 1
        self.early_polls += 1
        return self._start_poll(pick.choice, now, True)

    def handle_timer(self, now: float) -> None:
        """Every poll out whose deadline has passed is unanswered."""
        expired = [flight for flight in self._flights.values()
                   if now >= flight.request.deadline]
        if not expired:
            return
        for flight in sorted(expired, key=lambda flight: flight.request.deadline):
            self._unanswered(flight, now)

    def receive_end(self, follower: str, poll_seq: int, now: float) -> None:
        """No more replies can come to poll ``poll_seq`` of ``follower`` (Zenoh's get is
        over): unless a valid reply was taken, the poll is unanswered within
        ``END_GRACE`` (a reply and the get's end may come over two paths, the end first),
        not at its deadline, and the channel is free for the next."""
        flight = self._flights.get(follower)
        if flight is None or flight.request.poll_seq != poll_seq:
            return  # answered, or timed out before (a late reply may still be on its way)
        flight.request.deadline = min(flight.request.deadline, now + END_GRACE)

    # --- output ---

    def next_poll(self, now: float) -> PollRequest | None:
        """The poll to send now, put in flight; None while ``config.in_flight`` are out
        (with one out: the pick for after it is made), nobody is left to poll, no poll
        can find anything new before ``get_timer()`` (``sources``), or the poll picked
        is worth holding for its phased source's next update (``poll_hold``)."""
        out, allowed = self._flights, self.polls_allowed
        if len(out) >= allowed or len(out) >= len(self.table.ids):
            if allowed == 1:
                self._pick_ahead()
            return None
        if self._waits_for_sources(now):
            return None
        hold = self._hold
        if hold.until > -math.inf:
            if now < hold.until:
                return None
            hold.until = -math.inf
        pick, self._pick = self._pick, None
        if not out and pick is not None and pick.poll_seq == self._answered_seq \
                and still_holds(pick, self.table, now):
            fast, choice = True, pick.choice
        else:
            fast, choice = False, choose(self.table, self.policy, self.slot, now,
                                         {self.table.index(f) for f in out})
        if allowed == 1 and not out and self.table.known_intervals and self._pacing \
                and hold.holds(self.table, choice, now):
            return None
        if fast:
            self.fast_polls += 1
        return self._start_poll(choice, now, allowed == 1 and not out)

    def next_event(self) -> Event | None:
        """What happened, oldest first; None when nothing is left."""
        return self._events.popleft() if self._events else None

    def get_timer(self) -> float | None:
        """When ``handle_timer`` is due: the earliest deadline of the polls out, or,
        while another poll may go out, when the first source or probe is due, or when a
        poll held (``next_poll``) goes out."""
        flights = self._flights
        wake = math.inf
        if self._hold.until > -math.inf:  # (none out)
            wake = self._hold.until
        elif self._waits_for_sources(-math.inf) \
                and len(flights) < min(self.polls_allowed, len(self.table.ids)):
            wake = self.table.wake_at()
        if flights:
            wake = min(wake, min(flight.request.deadline for flight in flights.values()))
        return wake if math.isfinite(wake) else None

    def stats(self, follower: str, now: float, refused_before: int = 0) -> FollowerStats:
        """One follower's figures (one that left: ageing); ``refused_before``: its
        replies the shell refused before they reached the core (counted in ``errors``)."""
        return self.members.stats(follower, now, refused_before)

    def mean_aoi(self, follower: str, now: float) -> float:
        """A present follower's mean AoI so far (its ``stats`` without the rest)."""
        return self.members.peer(follower).aoi.mean(now)

    # --- inside ---

    def _waits_for_sources(self, now: float) -> bool:
        """No poll can find anything new before ``table.wake_at()`` (after ``now``):
        every live follower's source is paced and not due, no probe is due (a swarm of
        silent followers only is polled on). With no source paced and none silent: no
        pass over the table."""
        table = self.table
        return self._pacing and table.unfresh > 0 and table.silent < len(table) \
            and table.wake_at() > now

    def _reject(self, peer: Peer, follower: str, reason: str) -> None:
        peer.refused(first_for_poll=False)
        self._events.append(Rejected(follower, reason))

    def _unanswered(self, flight: Flight, now: float) -> None:
        """The poll of ``flight`` ends with no valid answer (a reply may still come
        after it, and teach how slow the link is)."""
        request, peer = flight.request, flight.peer
        del self._flights[request.follower]
        self._pick = None
        before = peer.reliability.value
        self._complete(request, now, peer, before,
                       peer.unanswered(request.poll_seq, request.sent_at, now))
        if self.tuner is not None:
            self.tuner.completed(False, now, len(self.table.ids))

    def _complete(self, request: PollRequest, now: float, peer: Peer, before: float,
                  outcome: list[Event]) -> None:
        """The poll ``request`` of ``peer`` is over: the slot, its ``outcome`` (events),
        and the p it shares with a site's followers (``before``: its p before)."""
        duration = max(now - request.sent_at, 1e-6)
        self.slot = SLOT_EMA * self.slot + (1.0 - SLOT_EMA) * duration
        self._events.extend(outcome)
        if peer.reliability.value != before:
            self._events.extend(self.site_links.shared_change(
                request.follower, before, self.table, self.config.window, now))

    def _pick_ahead(self) -> None:
        """With one poll out (the paper's rule), whom to poll after it (once per poll)."""
        if len(self._flights) != 1 or self._indexed is None:
            return
        request = next(iter(self._flights.values())).request
        if self._picked_for == request.poll_seq:
            return
        self._picked_for = request.poll_seq
        self._pick = pick_after(self.table, self._indexed, self.slot, request.poll_seq,
                                self.table.index(request.follower), request.sent_at + self.slot)

    def _start_poll(self, choice: int, now: float, alone: bool) -> PollRequest:
        """Put a poll of the follower at ``choice`` in the table in flight, with the
        control information if it changed or ``config.control_period`` has passed
        (steady if ``alone``: the only one out, but a poll answered; to a follower
        answering)."""
        follower = self.table.ids[choice]
        peer = self.table.peers[follower]
        hold = self._hold
        hold.held, hold.until = False, -math.inf
        self._poll_seq += 1
        self.polls += 1
        peer.polled()
        control = self._control.take(now)
        timing = peer.timing
        steady = alone and timing.unanswered == 0 \
            and not peer.silent and timing.measured
        poll = Poll(self._poll_seq, now, peer.ack, peer.want, self.epoch)
        request = PollRequest(
            follower, self._poll_seq, encode_poll(poll), now + timing.timeout, now,
            self._control.seq, control, self.epoch, steady,
        )
        self._flights[follower] = Flight(request, peer)
        return request
