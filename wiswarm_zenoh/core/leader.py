"""The leader's state machine: whom to poll, and what a reply or a timeout means."""

from __future__ import annotations

import math
import random
from collections.abc import Sequence

import numpy as np

from wiswarm_zenoh.core.ages import ages_in_slots, array_ages_in_slots
from wiswarm_zenoh.core.clock import STAMP_SLACK
from wiswarm_zenoh.core.config import LeaderConfig
from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.events import (
    Answering,
    Delivered,
    Event,
    Rejected,
    Silent,
    Stale,
    TimedOut,
)
from wiswarm_zenoh.core.fragments import verify_checksum
from wiswarm_zenoh.core.messages import MAX_INT
from wiswarm_zenoh.core.peers import FollowerStats, Peer, PeerTable
from wiswarm_zenoh.core.plausibility import implausible
from wiswarm_zenoh.core.policies import IndexPolicy, make_policy
from wiswarm_zenoh.core.poll_records import Answered, PollRequest, Prepared, Unsettled
from wiswarm_zenoh.core.scheduling import choose
from wiswarm_zenoh.core.wire import (
    Poll,
    Reply,
    Waypoint,
    decode_reply,
    encode_poll,
    pack_entries,
    validate_waypoints,
)

__all__ = ["FollowerStats", "Leader", "PollRequest"]

SLOT_EMA = 0.9  # smoothing of the mean poll duration, the "slot" of slotted policies


class Leader:
    """Sans-I/O leader (paper, Section II-D): one poll in flight at a time.

    The shell calls ``poll(now)`` when it can send, hands every reply to ``on_reply``,
    tells ``finish_poll`` when no more replies can come, and fires ``on_timer`` at
    ``next_timer()``. Bad bytes never raise: they come back as ``Rejected`` events and
    are counted against the follower.

    A shell in a hurry takes a reply in two steps: ``accept_reply`` does what choosing
    the next poll needs (the poll's outcome, the follower's new freshness), ``settle``
    the rest (checksum, AoI, the ``Delivered`` event), once the next poll is on its way.
    An update whose checksum then fails is rejected and its freshness withdrawn. Any
    call to ``accept_reply`` settles the reply before it first, so nothing is lost.

    A shell in more of a hurry also sends the next poll before it takes the reply at
    all: ``prepare`` (while the poll is out) picks among the other followers, with ages
    as at the time the reply is expected; ``reply_and_poll`` then checks the reply and
    the polled follower's new index against that pick, and returns the next poll, or
    None when the usual path must decide (see there).
    """

    def __init__(self, config: LeaderConfig | None = None, rng: random.Random | None = None,
                 epoch: int = 0) -> None:
        if type(epoch) is not int or not 0 <= epoch <= MAX_INT:
            raise ValueError(f"epoch must be an integer in [0, {MAX_INT}], got {epoch!r}")
        self.config = config or LeaderConfig()
        self.epoch = epoch  # in every poll and control: followers tell leaders apart by it
        self.policy = make_policy(self.config.policy, rng)
        self.table = PeerTable(self.config.weight_floor, self.config.price_by_time)
        self.unknown_replies = 0
        self.polls = 0
        self.fast_polls = 0  # polls sent by ``reply_and_poll``
        self.slot = 0.01  # mean poll duration in seconds, refined as polls complete
        self._poll_seq = 0
        self._control_seq = 0
        self._in_flight: PollRequest | None = None
        self._waypoints: dict[str, list[Waypoint]] = {}
        self._packed_control: bytes | None = None  # cache of the packed entries
        self._unsettled: Unsettled | None = None
        self._prepared: Prepared | None = None
        self._answered: Answered | None = None

    @property
    def followers(self) -> list[str]:
        return list(self.table.ids)

    @property
    def in_flight(self) -> str | None:
        return None if self._in_flight is None else self._in_flight.follower

    def add_follower(self, follower: str, now: float) -> None:
        """A follower joined, or rejoined after a restart (its transfer state is reset)."""
        if not follower:
            raise ValueError("follower id must be a non-empty string")
        self._prepared = None
        peer = self.table.peers.get(follower)
        if peer is None:
            self.table.add(follower, Peer.new(follower, self.config, now))
        else:
            peer.restart()

    def remove_follower(self, follower: str) -> None:
        """Forget a follower (its liveliness token went); a poll in flight to it is dropped."""
        if follower not in self.table.peers:
            return
        if self._in_flight is not None and self._in_flight.follower == follower:
            self._in_flight = None
        if self._unsettled is not None and self._unsettled.follower == follower:
            self._unsettled = None
        if self._answered is not None and self._answered.flight.follower == follower:
            self._answered = None
        self._prepared = None
        self.table.remove(follower)
        if self._waypoints.pop(follower, None) is not None:
            self._packed_control = None

    def _peer(self, follower: str) -> Peer:
        try:
            return self.table.peers[follower]
        except KeyError:
            raise ValueError(f"unknown follower {follower!r}") from None

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        """The application's latest control information for one follower."""
        self._peer(follower)
        self._waypoints[follower] = validate_waypoints(waypoints)
        self._packed_control = None

    def observe_urgency(self, follower: str, v: float) -> float:
        """Feed the application's urgency signal into the weight EMA; returns the weight."""
        weight = self._peer(follower).weight.observe(v)
        self.table.sync(follower)
        self._prepared = None
        return weight

    def poll(self, now: float) -> PollRequest | None:
        """Choose and build the next poll, or None while one is in flight or nobody is here."""
        if self._in_flight is not None or not self.table.ids:
            return None
        return self._start_poll(choose(self.table, self.policy, self.slot, now), now)

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
        self._in_flight = request
        return request

    def next_timer(self) -> float | None:
        return None if self._in_flight is None else self._in_flight.deadline

    def on_timer(self, now: float) -> list[Event]:
        flight = self._in_flight
        if flight is None or now < flight.deadline:
            return []
        return self._unanswered(flight, now)

    def finish_poll(self, now: float) -> list[Event]:
        """No more replies can come for the poll in flight: unanswered if none was valid."""
        flight = self._in_flight
        return [] if flight is None else self._unanswered(flight, now)

    def _unanswered(self, flight: PollRequest, now: float) -> list[Event]:
        peer = self.table.peers[flight.follower]
        self._in_flight = None
        peer.timed_out.append((flight.poll_seq, flight.sent_at))
        was_silent = peer.silent
        self._complete(flight, peer, answered=False, now=now)
        peer.timeouts += 1
        self.table.sync(flight.follower)
        events: list[Event] = [TimedOut(flight.follower, flight.poll_seq)]
        if peer.silent and not was_silent:
            peer.silent_since = now
            events.append(Silent(flight.follower, self.config.window))
        return events

    def _complete(self, flight: PollRequest, peer: Peer, answered: bool, now: float) -> None:
        """The poll ``flight`` is over (the caller syncs the policy arrays)."""
        duration = max(now - flight.sent_at, 1e-6)
        self.slot = SLOT_EMA * self.slot + (1.0 - SLOT_EMA) * duration
        if answered:
            peer.timing.answered(duration)
            typical = self.table.typical_success
            self.table.typical_success = duration if typical == 0.0 else \
                SLOT_EMA * typical + (1.0 - SLOT_EMA) * duration
        cfg = self.config
        peer.record_poll(answered, now, cfg.probe_interval, cfg.probe_max)

    def on_reply(self, follower: str, data: bytes, now: float) -> list[Event]:
        """Consume one reply from ``follower`` (the key it came from)."""
        events = self.accept_reply(follower, data, now)
        events.extend(self.settle())
        return events

    def accept_reply(self, follower: str, data: bytes, now: float) -> list[Event]:
        """The first step of ``on_reply``: enough for ``poll`` to choose well."""
        events = [] if self._unsettled is None and self._answered is None else self.settle()
        peer = self.table.peers.get(follower)
        if peer is None:
            self.unknown_replies += 1
            events.append(Stale(follower, "reply from a follower that is not a member"))
            return events
        try:
            reply = decode_reply(data, peer.expected)
        except WireError as exc:
            peer.errors += 1
            events.append(Rejected(follower, str(exc)))
            return events
        flight = self._in_flight
        if flight is None or flight.follower != follower or reply.poll_seq != flight.poll_seq:
            peer.stale += 1
            sent_at = _late(peer, reply.poll_seq) if reply.follower == follower else None
            if sent_at is not None:  # answered after its timeout: a slower link than measured
                peer.timing.answered(now - sent_at)
                self.table.sync(follower)
                return events
            events.append(Stale(follower, f"reply to poll {reply.poll_seq}, not the one in flight"))
            return events
        if reply.follower != follower:
            peer.errors += 1
            events.append(Rejected(follower, f"reply claims to come from {reply.follower!r}"))
            return events
        reason = implausible(flight, peer, reply, now)
        if reason is not None:  # not this follower's answer: the poll waits for the real one
            peer.errors += 1
            events.append(Rejected(follower, reason))
            return events
        self._in_flight = None
        self._take_answer(Answered(flight, peer, reply, now), events)
        return events

    def _take_answer(self, answered: Answered, events: list[Event]) -> None:
        """A valid answer's effects: the poll's outcome, the clock, the fragment."""
        flight, peer, reply, now = answered.flight, answered.peer, answered.reply, answered.now
        if peer.silent:
            events.append(Answering(flight.follower, now - peer.silent_since))
        self._complete(flight, peer, answered=True, now=now)
        peer.clock.add(flight.sent_at, reply.received_at, reply.sent_at, now)
        self._take_fragment(flight, peer, reply, now, events)
        self.table.sync(flight.follower)

    def prepare(self) -> None:
        """While a poll is in flight: pick whom to poll after it among the other
        followers, with ages as at the reply's expected time (sent + the mean poll
        duration). Skipped (``reply_and_poll`` then declines) unless the policy ranks
        by an index, nobody is silent and no earlier reply waits for ``settle``."""
        self._prepared = None
        flight, table, policy = self._in_flight, self.table, self.policy
        if (flight is None or not isinstance(policy, IndexPolicy) or len(table) < 2
                or table.silent or self._answered is not None or self._unsettled is not None):
            return
        at, slot, polled = flight.sent_at + self.slot, self.slot, table.index(flight.follower)
        if table.few:
            values = policy.indices(table.w, table.p, ages_in_slots(table.tau, at, slot))
            values[polled] = -math.inf
            best = max(values)
            choice = values.index(best)  # the first of equals, as the policies' own pick
        else:
            wa, pa, taua = table.arrays()
            indices = policy.index(wa, pa, array_ages_in_slots(taua, at, slot))
            indices[polled] = -np.inf
            choice = int(np.argmax(indices))
            best = float(indices[choice])
        self._prepared = Prepared(flight.poll_seq, at, choice, best, policy.index)

    def reply_and_poll(self, follower: str, data: bytes, now: float) -> PollRequest | None:
        """``accept_reply`` then ``poll`` in one step, most of the first left for
        ``settle``: if ``data`` is a valid answer to the poll in flight with nothing new
        or a whole update in one fragment, and the polled follower's new index (at the
        time ``prepare`` used, its clock offset as estimated before this reply) does not
        beat ``prepare``'s pick, the poll is over and the pick's poll is returned, in
        flight. None, with nothing changed, otherwise (bad or stale input, a fragment of
        a larger update, the follower still first, a reply later than twice the mean
        poll duration, nothing prepared): the shell then takes the usual path."""
        prepared, self._prepared = self._prepared, None
        flight = self._in_flight
        if (prepared is None or flight is None or flight.follower != follower
                or now > prepared.at + self.slot):  # late: the ages prepared are too old
            return None
        peer = self.table.peers[follower]
        try:
            reply = decode_reply(data, peer.expected)
        except WireError:
            return None
        frag = reply.fragment
        if (reply.poll_seq != prepared.poll_seq or reply.follower != follower
                or (frag is not None and frag.count != 1)
                or implausible(flight, peer, reply, now) is not None):
            return None
        fresh_from = now if frag is None else peer.clock.to_leader(frag.generated_at)
        age = max(prepared.at - max(peer.policy_tau, fresh_from), 0.0) / self.slot
        i = self.table.index(follower)
        value = prepared.index(self.table.w[i], peer.reliability.after(True), age)
        if value > prepared.value or (value == prepared.value and i < prepared.choice):
            return None
        self._in_flight = None
        self._answered = Answered(flight, peer, reply, now)
        self.fast_polls += 1
        return self._start_poll(prepared.choice, now)

    def _take_fragment(self, flight: PollRequest, peer: Peer, reply: Reply, now: float,
                       events: list[Event]) -> None:
        """Collect the reply's fragment; an update it completes waits for ``settle``,
        unless its time-stamp is ahead of ``now`` by more than the clock estimate's error
        can be (the poll's round trip, and some slack): such an update is refused."""
        follower, frag = flight.follower, reply.fragment
        if frag is None:
            peer.idle_since = now
            return
        try:
            whole = peer.reassembler.add(frag)
        except WireError as exc:
            peer.errors += 1
            peer.ack, peer.want = None, "fresh"
            events.append(Rejected(follower, str(exc)))
            return
        peer.ack, peer.want = (frag.update_seq, frag.index), "next"
        if whole is not None:
            generated_at = peer.clock.to_leader(frag.generated_at)
            ahead = generated_at - now
            if ahead > now - flight.sent_at + STAMP_SLACK:
                peer.errors += 1
                events.append(Rejected(follower, f"update stamped {ahead:.3f} s in the future"))
                return
            peer.unsettled_tau = generated_at
            self._unsettled = Unsettled(follower, peer, frag, whole, generated_at, now)

    def settle(self) -> list[Event]:
        """The second step of ``on_reply`` for the update accepted last (if any), and
        all of it for a reply taken by ``reply_and_poll``."""
        events: list[Event] = []
        answered, self._answered = self._answered, None
        if answered is not None:
            self._take_answer(answered, events)
        unsettled, self._unsettled = self._unsettled, None
        if unsettled is None:
            return events
        events.extend(self._verify(unsettled))
        return events

    def _verify(self, unsettled: Unsettled) -> list[Event]:
        """Checksum, AoI and delivery of an update taken whole."""
        follower, peer, frag = unsettled.follower, unsettled.peer, unsettled.frag
        peer.unsettled_tau = float("-inf")
        try:
            verify_checksum(unsettled.whole, frag)
        except WireError as exc:
            peer.errors += 1
            peer.ack, peer.want = None, "fresh"
            self.table.sync(follower)
            return [Rejected(follower, str(exc))]
        now = unsettled.now
        generated_at = min(unsettled.generated_at, now)  # ahead within the tolerance: now
        delivered = peer.aoi.deliver(generated_at, now)
        self.table.sync(follower)
        if not delivered:
            peer.stale += 1
            return [Stale(follower, "update older than the freshest delivered")]
        return [Delivered(follower, unsettled.whole, generated_at, now - generated_at,
                          frag.update_seq)]

    def stats(self, follower: str, now: float) -> FollowerStats:
        return self._peer(follower).stats(follower, now)


def _late(peer: Peer, poll_seq: int) -> float | None:
    """When poll ``poll_seq`` of ``peer`` was sent, if it went unanswered lately (and is
    then forgotten: one late reply teaches once)."""
    for entry in peer.timed_out:
        if entry[0] == poll_seq:
            peer.timed_out.remove(entry)
            return entry[1]
    return None
