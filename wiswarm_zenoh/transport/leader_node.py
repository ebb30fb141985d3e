"""The leader on Zenoh: discovery by liveliness, the poll loop, control and telemetry.

One thread owns the loop and keeps the polls the core allows in flight (one, the
paper's rule, unless ``LeaderConfig.in_flight`` says more). It feeds the core and pulls
from it, nothing else: a reply arrives, it is fed in (``receive_reply``), the next polls
go out (``next_poll``), the core's events are drained (``next_event``: the work a reply
brings is done then, while those polls are on their way) and handed on. Everything the
loop reacts to comes through one inbox: replies and the ends of gets, put there by
Zenoh's own thread (see ``links``), and wake-ups for membership changes. It waits on
that inbox until the core's timer (``get_timer``) or the next stats. A poll ends at its
valid answer, at the end of its get (nobody to answer it: ``receive_end``), or at the
core's timer; Zenoh's get stays open until the ceiling (``--timeout``), so a reply that
comes after the follower's adaptive deadline still reaches the core and lengthens that
timeout.
"""

from __future__ import annotations

import logging
import os
import queue
import random
import socket
import threading
import time
from collections.abc import Callable, Sequence
from types import TracebackType
from typing import TypeVar

import zenoh

from wiswarm_zenoh.core import (
    Answering,
    Delivered,
    FollowerStats,
    Leader,
    LeaderConfig,
    Rejected,
    Silent,
    Stale,
    TimedOut,
    drain,
)
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.bridge import BridgeOptions
from wiswarm_zenoh.transport.delivery_stream import DeliveryStream
from wiswarm_zenoh.transport.election import Election
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.links import FollowerLink
from wiswarm_zenoh.transport.membership import FORGET_AFTER, Membership
from wiswarm_zenoh.transport.silence import SilenceLog
from wiswarm_zenoh.transport.standby import Handover
from wiswarm_zenoh.transport.stats_rounds import StatsRounds
from wiswarm_zenoh.transport.telemetry import LeaderSummary, fresh_attachment
from wiswarm_zenoh.units import format_epoch

log = logging.getLogger(__name__)
T = TypeVar("T")
# A reply as its get brings it, or a get's end (the poll's sequence number); None: wake up
Arrival = tuple[FollowerLink, zenoh.Reply | int] | None

STATS_PERIOD = 0.4  # seconds: the contract asks for at least 2 Hz; stats cost a percentile
CONTROL_PERIOD = 0.1  # seconds between repeats of unchanged control information


def _notify(callback: Callable[[T], object], arg: T) -> None:
    """Run an application callback; its failure is logged, never the end of polling."""
    try:
        callback(arg)
    except Exception:
        log.exception("callback %r failed on %r", callback, arg)


class LeaderNode:
    """Polls the followers of ``swarm`` until ``close()``.

    Callbacks run on the poll thread (keep them short): ``on_delivery`` for every fresh
    update, ``on_join``/``on_leave`` as liveliness tokens come and go, ``on_role`` (True:
    active) once the role is decided and whenever it changes. The control
    information is put on ``wiswarm/<swarm>/control`` with the first poll after it
    changes (or a follower joins) and repeated every ``control_period`` seconds;
    ``control_period=0`` puts it with every poll. ``epoch`` (in every poll and control
    message) defaults to the start time in microseconds.

    Any number of leaders may run for a swarm: the oldest polls, the others stand by
    (``election``), following its control and the followers' weights (``standby``). A
    standby that takes over does so with an epoch above any it heard, and those weights
    and that control. ``name`` (default: host and process id) tells leaders apart in logs
    and in ``leader/stats``.

    A follower whose token goes is polled no more; its stats go on, ageing, for
    ``forget_after`` seconds (``membership``).

    ``bridge`` (e.g. ``wiswarm_zenoh.ros2.Ros2Options``) opens a bridge to another
    ecosystem, handed each delivery and each whole round of stats on the poll thread.
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
        on_role: Callable[[bool], None] | None = None,
        clock: Callable[[], float] = time.time,
        rng: random.Random | None = None,
        stats_period: float = STATS_PERIOD,
        control_period: float = CONTROL_PERIOD,
        epoch: int | None = None,
        name: str | None = None,
        forget_after: float = FORGET_AFTER,
        bridge: BridgeOptions | None = None,
    ) -> None:
        self.keys = SwarmKeys(swarm)
        self._session = session
        # A leader started later has a larger epoch: followers then take it as theirs.
        self._leader = Leader(config, rng, max(0, int(clock() * 1e6)) if epoch is None else epoch)
        self.config = self._leader.config
        self.name = name or f"{socket.gethostname()}-{os.getpid()}".replace(".", "-")
        self._active: bool | None = None  # this process polls (None: not decided yet)
        self._clock = clock
        self._on_delivery = on_delivery
        self._on_join = on_join
        self._on_leave = on_leave
        self._on_role = on_role
        self._control_period = control_period
        self._max_reply = self.config.max_update_bytes + FRAGMENT_HEADER_BYTES
        self._lock = threading.Lock()  # the core, between the poll thread and callers
        self._inbox: queue.SimpleQueue[Arrival] = queue.SimpleQueue()
        self._stop = threading.Event()
        self.bad_input = BadInputLog(log)
        self._silence = SilenceLog(lambda f: not self._stop.is_set() and f in self.followers)
        self._control_version = 0
        self._control_sent: tuple[int, float] = (-1, 0.0)  # (version, time) of the last put
        self._stats = StatsRounds(session, self.keys, stats_period, clock(),
                                  self.config.policy, self.name)
        self._deliveries = DeliveryStream(session, self.keys)
        self._control = session.declare_publisher(self.keys.control, express=True)
        self._membership = Membership(
            session, self.keys, self.config.timeout,
            lambda link, reply: self._inbox.put((link, reply)),
            lambda link, poll_seq: self._inbox.put((link, poll_seq)), lambda: self._inbox.put(None),
            self.bad_input, forget_after)
        self._links = self._membership.links
        self._handover = Handover(session, self.keys)
        self._handover.own_epoch = self._leader.epoch
        self._election = Election(session, self.keys, self.name, self._leader.epoch,
                                  lambda: self._inbox.put(None))
        self.bridge = None if bridge is None else bridge.open(session, swarm, self)
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
    def active(self) -> bool:
        """This process is the swarm's active leader (the others stand by)."""
        return bool(self._active)

    @property
    def latest(self) -> list[FollowerStats]:
        """The last whole round of followers' stats records (as published)."""
        return self._stats.latest

    @property
    def summary(self) -> LeaderSummary:
        """The last ``leader/stats`` published."""
        return self._stats.summary

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
        if self.bridge is not None:
            self.bridge.close()
        self._election.close()  # a standby takes over now
        self._handover.close()
        self._membership.close()
        self._deliveries.close()
        self._stats.close()
        undeclare(self._control)

    def __enter__(self) -> LeaderNode:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # --- Zenoh callbacks ---

    # --- the poll thread ---

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                if self._membership.changed:
                    self._apply_changes()
                if self._election.leading != self._active:
                    self._take_role()
                now = self._clock()
                if self._active:
                    self._poll(now)
                else:
                    self._hand_on()
                now = self._clock()
                if now >= self._stats.due:  # while the poll just sent is on its way
                    self._publish_stats(now)
                if now >= self._deliveries.due:
                    self._deliveries.flush()
                with self._lock:
                    timer = self._leader.get_timer()
                wake_at = min(self._stats.due, self._deliveries.due)
                wake_at = wake_at if timer is None else min(timer, wake_at)
                try:
                    arrival = self._inbox.get(timeout=max(0.0, wake_at - now))
                except queue.Empty:
                    with self._lock:
                        self._leader.handle_timer(self._clock())
                    continue
                if arrival is None:
                    continue
                link, reply = arrival
                if isinstance(reply, int):
                    with self._lock:
                        self._leader.receive_end(link.follower, reply, self._clock())
                    continue
                data = link.payload(reply, self._max_reply, self.bad_input)
                if data is not None:
                    with self._lock:
                        self._leader.receive_reply(link.follower, data, self._clock())
        finally:
            self._hand_on()

    def _take_role(self) -> None:
        """Become the active leader (with an epoch above any heard, and the weights and
        control the leader before left), or stand by."""
        self._active = self._election.leading
        if not self._active:
            log.info("leader %s stands by (an older leader is active: %s)", self.name,
                        self._election.active[1])
        else:
            self._raise_epoch(take_state=True)
            log.info("leader %s is active, epoch %s", self.name,
                     format_epoch(self._leader.epoch))
        if self._on_role is not None:
            _notify(self._on_role, self._active)

    def _raise_epoch(self, take_state: bool) -> None:
        """An epoch above any other leader's, so that followers take this one as theirs:
        the time now (in microseconds; any leader that became active before has a
        smaller one, even one this process never heard, as across a healed partition),
        and above any epoch heard, whatever the clocks."""
        heard, weights, control = self._handover.state()
        with self._lock:
            epoch = max(self._leader.epoch, heard + 1, int(self._clock() * 1e6))
            if take_state:
                self._leader.take_over(epoch, weights, control)
            elif epoch != self._leader.epoch:
                self._leader.take_over(epoch, {}, {})
            self._control_version += 1  # the followers learn the new epoch at once
        self._handover.own_epoch = epoch

    def _poll(self, now: float) -> None:
        """Send the polls the core has (one, or up to ``in_flight``), with the control
        information when due, then hand on what the core has to say while they are on
        their way."""
        while True:
            with self._lock:
                request = self._leader.next_poll(now)
                version = self._control_version
            if request is None:
                break
            sent_version, sent_at = self._control_sent
            if version != sent_version or now - sent_at >= self._control_period:
                self._control.put(request.control)
                self._control_sent = (version, now)
            self._links[request.follower].poll(request.payload, request.poll_seq)
        self._hand_on()

    def _hand_on(self) -> None:
        """Drain the core's events and hand each on: a delivery to ``fresh`` (if anyone
        listens) and the application, bad input to the log with its key."""
        with self._lock:
            events = drain(self._leader)
        for event in events:
            if isinstance(event, Delivered):
                link = self._links.get(event.follower)
                if link is not None and link.listening:
                    link.fresh.put(event.payload, attachment=fresh_attachment(event))
                self._deliveries.add(event, event.delivered_at)
                if self.bridge is not None:
                    _notify(self.bridge.deliver, event)
                if self._on_delivery is not None:
                    _notify(self._on_delivery, event)
            elif isinstance(event, TimedOut):
                self._deliveries.add(event, self._clock())
                log.debug("poll %d of %s unanswered", event.poll_seq, event.follower)
            elif isinstance(event, Rejected | Stale):  # Stale: late, after our own timeout
                self.bad_input.report(self.keys.update(event.follower), event.reason,
                                      expected=isinstance(event, Stale))
            elif isinstance(event, Silent) and not event.answered_before:
                log.info("follower %s has not answered its first poll (not up yet, no "
                         "queryable, or no valid reply): probing it alone", event.follower)
            elif isinstance(event, Silent):
                self._silence.silent(event.follower, event.polls)
            elif isinstance(event, Answering):
                self._silence.answering(event.follower, event.silent_for)

    def _apply_changes(self) -> None:
        for follower, joined in self._membership.apply(self._leader, self._lock, self._clock()):
            if joined:
                with self._lock:
                    self._control_version += 1  # the newcomer needs the control now
            callback = self._on_join if joined else self._on_leave
            if callback is not None:
                _notify(callback, follower)

    def _publish_stats(self, now: float) -> None:
        """The stats due by ``now``, from the active leader only; at each new round, an
        active leader that hears an epoch as high as its own (two active across a
        partition) rises above it first."""
        if self._stats.between_rounds:
            self._membership.forget_departed(self._leader, self._lock, now)
        if not self._active:
            self._stats.pause(now)
            return
        if self._stats.between_rounds and self._handover.epoch >= self._leader.epoch:
            self._raise_epoch(take_state=False)
        latest = self._stats.latest
        self._stats.publish(now, self._leader, self._lock, self._links)
        if self.bridge is not None and self._stats.latest is not latest:  # a round is done
            bridge = self.bridge
            _notify(lambda records: bridge.stats(records, now), self._stats.latest)
