"""The leader on Zenoh: the core's thin shell (aioquic's asyncio adapter is the model).

Two poll threads own the core, one at a time, under one lock that no caller shares:
while one waits on a steady poll's own reply channel with the lock let go
(``steady_gets``: the bare get loop's path), the other waits on the inbox (replies and
ends of other gets from Zenoh's thread, membership changes, the application's calls)
and the timer; whichever wakes feeds the core and sends its polls and events on
(``outlets``). A get stays open to the ceiling: a reply after the adaptive deadline
still teaches.
"""

from __future__ import annotations

import logging
import math
import os
import queue
import random
import socket
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager, ExitStack
from functools import partial
from typing import TypeVar

import zenoh

from wiswarm_zenoh.core import Delivered, FollowerStats, Leader, LeaderConfig, validate_waypoints
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.bridge import BridgeOptions
from wiswarm_zenoh.transport.discovery import Discovery
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.leader_role import LeaderRole
from wiswarm_zenoh.transport.links import FollowerLink
from wiswarm_zenoh.transport.membership import FORGET_AFTER, Membership
from wiswarm_zenoh.transport.outlets import Outlets
from wiswarm_zenoh.transport.stats_rounds import STATS_PERIOD, StatsRounds
from wiswarm_zenoh.transport.steady_gets import SteadyGet, SteadyGets
from wiswarm_zenoh.transport.telemetry import LeaderSummary
from wiswarm_zenoh.transport.weight_settings import WeightPresets, WeightSettings

log = logging.getLogger(__name__)
T = TypeVar("T")
Command = Callable[[], object] | None  # what a poll thread does next (None: wake up)
POLL_THREADS = 2  # one may wait on a steady get while the other keeps inbox and timer


class LeaderNode(AbstractContextManager["LeaderNode"]):
    """Polls the followers of ``swarm`` until ``close()``.

    Callbacks run on a poll thread, one at a time (keep them short): ``on_delivery`` for every fresh
    update, ``on_join``/``on_leave`` as liveliness tokens come and go, ``on_role`` (True:
    active) as the role is decided. ``epoch`` defaults to the start time in µs. The
    oldest of a swarm's leaders polls, the others stand by (``leader_role``); ``name``
    (default: host and process id) tells them apart. A follower that left ages in the
    stats for ``forget_after`` s. ``bridge`` (e.g. ``wiswarm_zenoh.ros2.Ros2Options``)
    gets each delivery and round of stats. A follower's stats are made while someone
    subscribes to them, or always with ``every_record`` (for ``latest``). ``weights``:
    members' weights given before they join (``wiswarm leader --weight``:
    ``WeightPresets``).
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
        every_record: bool = False,
        epoch: int | None = None,
        name: str | None = None,
        forget_after: float = FORGET_AFTER,
        bridge: BridgeOptions | None = None,
        weights: Mapping[str, float] | None = None,
    ) -> None:
        self.keys = SwarmKeys(swarm)
        # A leader started later has a larger epoch: followers then take it as theirs.
        self._leader = Leader(config, rng, max(0, int(clock() * 1e6)) if epoch is None else epoch)
        self.config = self._leader.config
        self._presets = WeightPresets(self._leader, weights or {}, clock())  # before joins
        self._clock = clock
        self._max_reply = self.config.max_update_bytes + FRAGMENT_HEADER_BYTES
        self._inbox: queue.SimpleQueue[Command] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._stopping = False  # ``_stop`` as a plain flag, read on every poll
        self.bad_input = BadInputLog(log)
        put = self._inbox.put
        # What is built is closed in reverse order, by ``close``, or here at once if the
        # building stops (an error, or Ctrl-C / SIGTERM while the leader starts): its
        # threads would otherwise poll on while the caller closes the session under them.
        self._closing = closing = ExitStack()
        try:
            self._on_join = on_join
            self._membership = Membership(session, self.keys, self._leader, clock, put,
                                          self._reply, self._end, self.bad_input, forget_after,
                                          self._joined, on_leave)
            closing.callback(self._membership.close)
            self.name = name or f"{socket.gethostname()}-{os.getpid()}".replace(".", "-")
            self._role_news = True  # the election may have changed its verdict: look
            self._role = LeaderRole(session, self.keys, self.name, self._leader,
                                    self._role_changed, on_role)
            closing.callback(self._role.close)
            self._stats = StatsRounds(session, self.keys, stats_period, clock(),
                                      self.config.policy, self.name,
                                      every_record or bridge is not None)
            closing.callback(self._stats.close)
            self._outlets = Outlets(session, self.keys, self._membership.links, self.bad_input,
                                    on_delivery, clock, lambda f: not self._stop.is_set() and
                                    f in self._membership.followers)
            closing.callback(self._outlets.close)
            self._steady = self._outlets.steady = SteadyGets(self._leader, self._answer,
                                                             self._reply, self._end)
            self.bridge = self._outlets.bridge = \
                None if bridge is None else bridge.open(session, swarm, self)
            if self.bridge is not None:
                closing.callback(self.bridge.close)
            self._weights = WeightSettings(session, self.keys, self.set_weight, self.bad_input)
            closing.callback(self._weights.close)
            self._lock = threading.Lock()  # the core's: held by the poll thread feeding it
            self._threads = [threading.Thread(target=self._run, name=f"leader-{swarm}/{i + 1}",
                                              daemon=True) for i in range(POLL_THREADS)]
            closing.callback(self._stop_polling)  # first, once they may run
            for thread in self._threads:
                thread.start()
        except BaseException:
            closing.close()
            raise

    # --- for the application (any thread) ---

    @property
    def followers(self) -> list[str]:
        """The followers polled (as of the last change of membership)."""
        return list(self._membership.followers)

    @property
    def discovery(self) -> Discovery:
        """How the followers' tokens are found: its ``reasks`` and ``found_by_answer``
        say how often asking again found one the liveliness watch had missed."""
        return self._membership.discovery

    @property
    def polls(self) -> int:
        """Polls sent so far."""
        return self._leader.polls

    @property
    def epoch(self) -> int:
        """This leader's epoch, in every poll and control message it sends."""
        return self._leader.epoch

    @property
    def active(self) -> bool:
        """This process is the swarm's active leader (the others stand by)."""
        return bool(self._role.active)

    @property
    def latest(self) -> list[FollowerStats]:
        """The last round's followers' stats (with ``every_record``: all of them)."""
        return self._stats.latest

    @property
    def summary(self) -> LeaderSummary:
        """The last ``leader/stats`` published."""
        return self._stats.summary

    @property
    def fast_polls(self) -> int:
        """Polls sent on the pick made while the poll before was out (``Leader``)."""
        return self._leader.fast_polls

    @property
    def early_polls(self) -> int:
        """Of them, those sent before the reply they follow was judged."""
        return self._leader.early_polls

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        """New control for one follower, broadcast with the next poll (ValueError at once
        for waypoints no follower may be sent, or a follower not polled)."""
        checked = validate_waypoints(waypoints)
        if follower not in self._membership.followers:
            raise ValueError(f"unknown follower {follower!r}")
        self._inbox.put(partial(self._apply, self._leader.set_control, follower, checked))

    def expect(self, follower: str) -> None:
        """``follower`` is there by another sign than its member token (a bridge saw its
        source token): its token is asked for faster until it joins."""
        self._membership.expect(follower)

    def observe_urgency(self, follower: str, v: float) -> None:
        """The application's urgency signal for one follower, into its weight's EMA."""
        self._inbox.put(partial(self._apply, self._leader.observe_urgency, follower, v))

    def set_weight(self, follower: str, weight: float) -> None:
        """An operator's weight for one follower, as the weight key sets it
        (``weight_settings``); ValueError at once for a follower not polled or a weight
        that is not a number >= 0."""
        if not (math.isfinite(weight) and weight >= 0.0):
            raise ValueError(f"a weight must be a number >= 0, got {weight!r}")
        if follower not in self._membership.followers:
            raise ValueError(f"unknown follower {follower!r}")
        log.info("%s: weight set to %g", follower, weight)
        self._inbox.put(partial(self._apply, self._leader.set_weight, follower, weight))

    def close(self) -> None:
        """Stop polling (waits for the poll in flight) and undeclare everything."""
        self._closing.close()

    def _stop_polling(self) -> None:
        self._stop.set()
        self._stopping = True
        self._inbox.put(None)
        with self._lock:
            self._steady.close()  # lets go of a get a poll thread waits on
        for thread in self._threads:
            if thread.ident is not None:  # (not if its start was interrupted)
                thread.join()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- the poll threads ---

    def _run(self) -> None:
        leader, lock, inbox = self._leader, self._lock, self._inbox
        steady: SteadyGet | None = None  # a steady poll's get, to wait on
        lock.acquire()
        try:
            while not self._stopping:
                if self._role_news:  # (a flag, not the election's lock, on every poll)
                    self._role_news = False
                    if self._role.changed:
                        self._role.take(self._clock())
                now = self._clock()
                while self._role.active and (request := leader.next_poll(now)) is not None:
                    if (get := self._outlets.send(request)) is not None:  # (or ``in_flight``)
                        steady = get
                self._hand_on()
                now, deliveries = self._clock(), self._outlets.deliveries
                if now >= self._stats.due:  # while the poll just sent is on its way
                    self._publish_stats(now)
                if now >= deliveries.due:
                    deliveries.flush()
                if now >= self._steady.sweep_at:
                    self._steady.sweep(now)
                if steady is not None:  # the other poll thread keeps inbox and timer
                    steady = self._steady.wait(steady, lock)  # the next, if sent on its answer
                    continue
                timer = leader.get_timer()
                wake_at = math.inf if timer is None else timer
                if timer is None or not self._steady.busy:  # else the thread waiting on a
                    # steady get does the stats and the delivery stream between its polls
                    wake_at = min(wake_at, self._stats.due, deliveries.due)
                lock.release()
                try:
                    command: Command = inbox.get(timeout=max(0.0, wake_at - now))
                except queue.Empty:
                    command = self._timer
                finally:
                    lock.acquire()
                while True:  # all that came meanwhile (a reply and its get's end: one wake)
                    if command is not None:
                        command()
                    try:  # (the other poll thread, waiting on the inbox, may take it first)
                        command = inbox.get_nowait()
                    except queue.Empty:
                        break
        finally:
            self._hand_on()
            lock.release()
            inbox.put(None)  # the wake ``close`` sent may have been taken here: pass it on

    def _role_changed(self) -> None:  # on Zenoh's thread
        self._role_news = True
        self._inbox.put(None)

    def _joined(self, follower: str) -> None:  # on the poll thread
        self._outlets.rejoined(follower)
        if self._on_join is not None:
            self._on_join(follower)

    def _timer(self) -> None:
        self._leader.handle_timer(self._clock())

    def _hand_on(self) -> None:  # the core's events
        while (event := self._leader.next_event()) is not None:
            self._outlets.hand_on(event)

    def _answer(self, link: FollowerLink, reply: zenoh.Reply) -> SteadyGet | None:
        """A steady poll's reply: the next poll first, where the reply alone decides it
        (``Leader.poll_on_answer``), then the judging; that poll's get, if steady."""
        data = link.payload(reply, self._max_reply, self.bad_input)
        if data is None:
            return None
        leader, now, following = self._leader, self._clock(), None
        if self._role.active and not self._stopping \
                and (request := leader.poll_on_answer(link.follower, data, now)) is not None:
            following = self._outlets.send(request)
        leader.receive_reply(link.follower, data, now)
        return following

    def _reply(self, link: FollowerLink, reply: zenoh.Reply) -> None:
        data = link.payload(reply, self._max_reply, self.bad_input)
        if data is not None:
            self._leader.receive_reply(link.follower, data, self._clock())

    def _end(self, link: FollowerLink, poll_seq: int) -> None:
        self._leader.receive_end(link.follower, poll_seq, self._clock())

    def _apply(self, change: Callable[[str, T], object], follower: str, value: T) -> None:
        """An application's call, in the core (dropped if its follower left meanwhile)."""
        try:
            change(follower, value)
        except ValueError as exc:
            log.info("not applied: %s", exc)

    def _publish_stats(self, now: float) -> None:
        """The stats due; at a new round, followers gone long are forgotten first."""
        if self._stats.between_rounds:
            self._membership.forget_departed(now)
            self._role.hold(now)
            self._presets.look(now)
        self._stats.tick(now, self._leader, self._membership.links, self._role.active,
                         self.bridge)
