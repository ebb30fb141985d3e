"""The leader on Zenoh: discovery by liveliness, the poll loop, control and telemetry.

One thread owns the loop and keeps exactly one poll in flight. Everything it reacts to
comes through one inbox: each get's replies and its end (put by Zenoh's own thread, see
``links``) and wake-ups for membership changes. It waits on that inbox until the core's
timer (the poll's adaptive deadline) or the next stats; the core's timer is what ends a
poll, and Zenoh's get stays open until the ceiling (``--timeout``), so a reply that
comes after its deadline still reaches the core and lengthens that follower's timeout.
A get that Zenoh closes with no valid reply before the deadline (nobody answers on the
key) ends the poll at once.

While a poll is out, the core picks whom to poll next if the reply comes as usual
(``prepare``); when it comes, ``reply_and_poll`` checks it against that pick and the next
poll goes out at once. The rest of taking the reply (the poll's outcome, the clock,
reassembly, checksum, AoI, the delivery), the ``fresh`` re-publication and
``on_delivery`` run while that next poll is on its way. When the core declines (bad
input, a fragment of a larger update, the polled follower still first in line), the
reply is taken the usual way: ``accept_reply``, then ``poll``.
"""

from __future__ import annotations

import logging
import queue
import random
import threading
import time
from collections import Counter, deque
from collections.abc import Callable, Sequence
from types import TracebackType
from typing import TypeVar

import zenoh

from wiswarm_zenoh.core import (
    Answering,
    Delivered,
    Event,
    Leader,
    LeaderConfig,
    PollRequest,
    Rejected,
    Silent,
    Stale,
)
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.links import FollowerLink
from wiswarm_zenoh.transport.telemetry import (
    LeaderSummary,
    follower_stats,
    fresh_attachment,
    to_json,
)

log = logging.getLogger(__name__)
T = TypeVar("T")
# (link, poll seq, reply) as a get brings it, reply None when the get ends; None: a wake-up
Arrival = tuple[FollowerLink, int, zenoh.Reply | None] | None

STATS_PERIOD = 0.4  # seconds: the contract asks for at least 2 Hz; stats cost a percentile
CONTROL_PERIOD = 0.1  # seconds between repeats of unchanged control information
ZENOH_TIMEOUT = b"Timeout"  # the error reply Zenoh itself gives a get that timed out


def _notify(callback: Callable[[T], object], arg: T) -> None:
    """Run an application callback; its failure is logged, never the end of polling."""
    try:
        callback(arg)
    except Exception:
        log.exception("callback %r failed on %r", callback, arg)


class LeaderNode:
    """Polls the followers of ``swarm`` until ``close()``.

    Callbacks run on the poll thread (keep them short): ``on_delivery`` for every fresh
    update, ``on_join``/``on_leave`` as liveliness tokens come and go. The control
    information is put on ``wiswarm/<swarm>/control`` with the first poll after it
    changes (or a follower joins) and repeated every ``control_period`` seconds;
    ``control_period=0`` puts it with every poll. ``epoch`` (in every poll and control
    message) defaults to the start time in microseconds.
    """

    def __init__(
        self,
        session: zenoh.Session,
        swarm: str,
        config: LeaderConfig | None = None,
        *,
        on_delivery: Callable[[Delivered], None] | None = None,
        on_join: Callable[[str], None] | None = None,
        on_leave: Callable[[str], None] | None = None,
        clock: Callable[[], float] = time.time,
        rng: random.Random | None = None,
        stats_period: float = STATS_PERIOD,
        control_period: float = CONTROL_PERIOD,
        epoch: int | None = None,
    ) -> None:
        self.keys = SwarmKeys(swarm)
        self._session = session
        # A leader started later has a larger epoch: followers then take it as theirs.
        self._leader = Leader(config, rng, max(0, int(clock() * 1e6)) if epoch is None else epoch)
        self.config = self._leader.config
        self._clock = clock
        self._on_delivery = on_delivery
        self._on_join = on_join
        self._on_leave = on_leave
        self._stats_period = stats_period
        self._control_period = control_period
        self._max_reply = self.config.max_update_bytes + FRAGMENT_HEADER_BYTES
        self._lock = threading.Lock()  # the core, between the poll thread and callers
        self._changes: deque[tuple[str, bool]] = deque()
        self._inbox: queue.SimpleQueue[Arrival] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._links: dict[str, FollowerLink] = {}
        self._flight: int | None = None  # the seq of the poll in flight, as sent
        self._delivered: list[Delivered] = []  # not handed over yet
        self._transport_errors: Counter[str] = Counter()
        self.bad_input = BadInputLog(log)
        self._control_version = 0
        self._control_sent: tuple[int, float] = (-1, 0.0)  # (version, time) of the last put
        self._started = clock()
        self._stats_mark = (self._started, 0)  # (time, polls) at the last stats
        self._next_stats = self._started
        self.latest: list[dict[str, float | int | str]] = []
        self.summary = LeaderSummary([], 0.0, 0.0, self.config.policy, 0.0)
        self._control = session.declare_publisher(self.keys.control, express=True)
        self._leader_stats = session.declare_publisher(
            self.keys.leader_stats, encoding=zenoh.Encoding.APPLICATION_JSON
        )
        self._members = session.liveliness().declare_subscriber(
            self.keys.members, self._on_member, history=True
        )
        self._thread = threading.Thread(target=self._run, name=f"leader-{swarm}", daemon=True)
        self._thread.start()

    # --- calls from the application (any thread) ---

    @property
    def followers(self) -> list[str]:
        with self._lock:
            return self._leader.followers

    @property
    def polls(self) -> int:
        return self._leader.polls

    @property
    def epoch(self) -> int:
        """This leader's epoch, in every poll and control message it sends."""
        return self._leader.epoch

    @property
    def fast_polls(self) -> int:
        """Polls sent the moment the reply before them came (see the module's docstring)."""
        return self._leader.fast_polls

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        """New control information for one follower, broadcast with the next poll."""
        with self._lock:
            self._leader.set_control(follower, waypoints)
            self._control_version += 1

    def observe_urgency(self, follower: str, v: float) -> float:
        with self._lock:
            return self._leader.observe_urgency(follower, v)

    def close(self) -> None:
        """Stop polling (waits for the poll in flight) and undeclare everything."""
        self._stop.set()
        self._inbox.put(None)
        self._thread.join()
        undeclare(self._members)
        for link in self._links.values():
            link.close()
        self._links.clear()
        undeclare(self._control, self._leader_stats)

    def __enter__(self) -> LeaderNode:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # --- Zenoh callbacks ---

    def _on_member(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        follower = self.keys.follower_of(key, "members")
        if follower is None:
            self.bad_input.report(key, "not a valid member key")
            return
        self._changes.append((follower, sample.kind == zenoh.SampleKind.PUT))
        self._inbox.put(None)

    # --- the poll thread ---

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                if self._changes:
                    self._apply_changes()
                now = self._clock()
                if now >= self._next_stats:
                    self._publish_stats(now)
                if self._flight is None:
                    with self._lock:
                        request = self._leader.poll(now)
                        version = self._control_version
                    if request is not None:
                        self._send(request, version, now)
                    else:
                        self._settle()
                with self._lock:
                    timer = self._leader.next_timer()
                wake_at = self._next_stats if timer is None else min(timer, self._next_stats)
                try:
                    arrival = self._inbox.get(timeout=max(0.0, wake_at - now))
                except queue.Empty:
                    self._on_timer()
                    continue
                if arrival is not None:
                    self._arrive(*arrival)
        finally:
            self._settle()

    def _send(self, request: PollRequest, version: int, now: float) -> None:
        """Send a poll (and the control information, when due); then, while it is on its
        way, finish taking the last reply and pick whom to poll after it."""
        sent_version, sent_at = self._control_sent
        if version != sent_version or now - sent_at >= self._control_period:
            self._control.put(request.control)
            self._control_sent = (version, now)
        link, seq, inbox = self._links[request.follower], request.poll_seq, self._inbox
        self._flight = seq
        link.poll(request.payload, lambda reply: inbox.put((link, seq, reply)),
                  lambda: self._ended(link, seq))
        self._settle()
        with self._lock:
            self._leader.prepare()

    def _ended(self, link: FollowerLink, seq: int) -> None:
        """Zenoh closed a get (on its own thread). Only the poll in flight needs to know:
        its end means nobody answered. Any other's would wake the loop for nothing, once
        per poll."""
        if seq == self._flight:  # checked again on the loop, which owns ``_flight``
            self._inbox.put((link, seq, None))

    def _arrive(self, link: FollowerLink, seq: int, reply: zenoh.Reply | None) -> None:
        """One thing a get brought: a reply for the core, or its end."""
        now = self._clock()
        current = seq == self._flight
        if reply is None:  # Zenoh closed the get: if the poll is still out, nobody answered
            if current:
                with self._lock:
                    events = self._leader.finish_poll(now)
                self._flight = None
                self._dispatch(events)
            return
        data = self._payload(link, reply)
        if data is None:
            return
        if current:
            with self._lock:
                request = self._leader.reply_and_poll(link.follower, data, now)
                version = self._control_version
            if request is not None:
                self._send(request, version, now)
                return
        with self._lock:
            events = self._leader.accept_reply(link.follower, data, now)
            if current and self._leader.in_flight is None:
                self._flight = None
        if events:
            self._dispatch(events)

    def _on_timer(self) -> None:
        """The core's timer: the poll in flight is over if its deadline passed."""
        with self._lock:
            events = self._leader.on_timer(self._clock())
            if self._leader.in_flight is None:
                self._flight = None
        if events:
            self._dispatch(events)

    def _payload(self, link: FollowerLink, reply: zenoh.Reply) -> bytes | None:
        """A reply's bytes, or None for an error reply or one over the size limit (counted
        and logged; a timeout is no error: ``finish_poll`` counts it)."""
        sample = reply.ok
        if sample is None:
            reason = b"" if reply.err is None else reply.err.payload.to_bytes()[:80]
            if reason != ZENOH_TIMEOUT:
                self._transport_errors[link.follower] += 1
                self.bad_input.report(link.key, f"error reply {reason!r}")
            return None
        data = sample.payload.to_bytes()  # Zenoh holds it whole already: copy, then judge
        if len(data) > self._max_reply:
            self._transport_errors[link.follower] += 1
            self.bad_input.report(link.key, f"reply of {len(data)} bytes exceeds the limit")
            return None
        return data

    def _settle(self) -> None:
        """The core's second step for the last reply, and its delivery handed on."""
        with self._lock:
            events = self._leader.settle()
        if events:
            self._dispatch(events)
        if self._delivered:
            self._hand_over()

    def _dispatch(self, events: list[Event]) -> None:
        """Report bad input now; keep deliveries for ``_hand_over``."""
        for event in events:
            if isinstance(event, Delivered):
                self._delivered.append(event)
            elif isinstance(event, Rejected | Stale):
                self.bad_input.report(self.keys.update(event.follower), event.reason)
            elif isinstance(event, Silent):
                log.warning("follower %s stopped answering (its last %d polls went "
                            "unanswered): probing it alone now", event.follower, event.polls)
            elif isinstance(event, Answering):
                log.warning("follower %s answers again, after %.1f s", event.follower,
                            event.silent_for)
            else:
                log.debug("poll %d of %s unanswered", event.poll_seq, event.follower)

    def _hand_over(self) -> None:
        """Deliveries go out once the next poll is sent: re-publishing them and the
        application's callback then overlap that poll's round trip instead of delaying it."""
        delivered, self._delivered = self._delivered, []
        for event in delivered:
            link = self._links.get(event.follower)
            if link is not None and link.listening:
                link.fresh.put(event.payload, attachment=fresh_attachment(event))
            if self._on_delivery is not None:
                _notify(self._on_delivery, event)

    def _apply_changes(self) -> None:
        self._settle()  # a reply taken on the fast path, before its follower changes
        while self._changes:
            follower, joined = self._changes.popleft()
            now = self._clock()
            with self._lock:
                if joined:
                    self._leader.add_follower(follower, now)
                    self._control_version += 1  # the newcomer needs the control now
                else:
                    self._leader.remove_follower(follower)
                    if self._leader.in_flight is None:  # its poll, if it was out, is over
                        self._flight = None
            if joined:
                if follower not in self._links:
                    self._links[follower] = FollowerLink.open(
                        self._session, self.keys, follower, self.config.timeout)
                log.info("follower %s joined", follower)
                if self._on_join is not None:
                    _notify(self._on_join, follower)
                continue
            link = self._links.pop(follower, None)
            if link is None:
                continue
            link.close()
            self._transport_errors.pop(follower, None)
            log.warning("follower %s left (its liveliness token is gone)", follower)
            if self._on_leave is not None:
                _notify(self._on_leave, follower)

    def _publish_stats(self, now: float) -> None:
        self._settle()  # so that the stats count the last delivery
        with self._lock:
            records = [
                follower_stats(self._leader.stats(f, now), self._transport_errors[f])
                for f in self._leader.followers
            ]
            polls = self._leader.polls
        for record in records:
            link = self._links.get(str(record["follower"]))
            if link is not None:
                link.stats.put(to_json(record))
        mark_time, mark_polls = self._stats_mark
        rate = (polls - mark_polls) / (now - mark_time) if now > mark_time else 0.0
        summary = LeaderSummary.of(records, rate, self.config.policy, now - self._started)
        self._leader_stats.put(to_json(summary.as_dict()))
        self.latest, self.summary = records, summary
        self._stats_mark = (now, polls)
        self._next_stats = now + self._stats_period
