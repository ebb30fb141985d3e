"""The leader on Zenoh: the core's thin shell (aioquic's asyncio adapter is the model).

One thread owns the core. It feeds it (replies and the ends of gets, put in one inbox
by Zenoh's thread through ``links``; membership; the application's calls, which come
as commands through the same inbox, so no lock is shared with any caller; the timer),
sends the polls it gives, each with the control broadcast when the core says, and
hands its events on (``outlets``). Zenoh's get stays open until the ceiling
(``--timeout``): a reply after the adaptive deadline still teaches the core.
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
from functools import partial
from types import TracebackType

import zenoh

from wiswarm_zenoh.core import Delivered, FollowerStats, Leader, LeaderConfig, validate_waypoints
from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.bridge import BridgeOptions
from wiswarm_zenoh.transport.delivery_stream import DeliveryStream
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.leader_role import LeaderRole
from wiswarm_zenoh.transport.links import FollowerLink
from wiswarm_zenoh.transport.membership import FORGET_AFTER, Membership
from wiswarm_zenoh.transport.outlets import Outlets, notify
from wiswarm_zenoh.transport.stats_rounds import StatsRounds
from wiswarm_zenoh.transport.telemetry import LeaderSummary

log = logging.getLogger(__name__)
# A reply as its get brings it, a get's end (the poll's sequence number), an
# application's command, or None: wake up
Arrival = tuple[FollowerLink, zenoh.Reply | int] | Callable[[], object] | None

STATS_PERIOD = 0.4  # seconds: the contract asks for at least 2 Hz; stats cost a percentile


class LeaderNode:
    """Polls the followers of ``swarm`` until ``close()``.

    Callbacks run on the poll thread (keep them short): ``on_delivery`` for every fresh
    update, ``on_join``/``on_leave`` as liveliness tokens come and go, ``on_role`` (True:
    active) once the role is decided and whenever it changes. ``epoch`` (in every poll
    and control message) defaults to the start time in microseconds. Any number of
    leaders may run: the oldest polls, the others stand by (``leader_role``); ``name``
    (default: host and process id) tells them apart. A follower whose token goes is
    polled no more; its stats go on, ageing, for ``forget_after`` seconds. ``bridge``
    (e.g. ``wiswarm_zenoh.ros2.Ros2Options``) is handed each delivery and each round
    of stats on the poll thread.
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
        epoch: int | None = None,
        name: str | None = None,
        forget_after: float = FORGET_AFTER,
        bridge: BridgeOptions | None = None,
    ) -> None:
        self.keys = SwarmKeys(swarm)
        # A leader started later has a larger epoch: followers then take it as theirs.
        self._leader = Leader(config, rng, max(0, int(clock() * 1e6)) if epoch is None else epoch)
        self.config = self._leader.config
        self._clock, self._on_role = clock, on_role
        self._max_reply = self.config.max_update_bytes + FRAGMENT_HEADER_BYTES
        self._inbox: queue.SimpleQueue[Arrival] = queue.SimpleQueue()
        self._stop = threading.Event()
        self.bad_input = BadInputLog(log)
        put = self._inbox.put
        self._membership = Membership(
            session, self.keys, self._leader, clock, put, lambda link, reply: put((link, reply)),
            lambda link, poll_seq: put((link, poll_seq)), self.bad_input, forget_after)
        self._membership.on_join, self._membership.on_leave = on_join, on_leave
        self._links = self._membership.links
        name = name or f"{socket.gethostname()}-{os.getpid()}".replace(".", "-")
        self._role = LeaderRole(session, self.keys, name, self._leader, partial(put, None))
        self._stats = StatsRounds(session, self.keys, stats_period, clock(),
                                  self.config.policy, name)
        self._deliveries = DeliveryStream(session, self.keys)
        self._control = session.declare_publisher(self.keys.control, express=True)
        self._outlets = Outlets(self.keys, self._links, self._deliveries, self.bad_input,
                                on_delivery, clock)
        self.bridge = self._outlets.bridge = \
            None if bridge is None else bridge.open(session, swarm, self)
        self._thread = threading.Thread(target=self._run, name=f"leader-{swarm}", daemon=True)
        self._thread.start()

    # --- calls from the application (any thread) ---

    @property
    def followers(self) -> list[str]:
        """The followers polled, as of the last change of membership."""
        return list(self._membership.followers)

    @property
    def polls(self) -> int:
        """Polls sent so far."""
        return self._leader.polls

    @property
    def epoch(self) -> int:
        """This leader's epoch, in every poll and control message it sends."""
        return self._leader.epoch

    @property
    def name(self) -> str:
        """Its name among the swarm's leaders (logs, ``leader/stats``)."""
        return self._role.name

    @property
    def active(self) -> bool:
        """This process is the swarm's active leader (the others stand by)."""
        return bool(self._role.active)

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
        """New control information for one follower, broadcast with the next poll.
        Raises ValueError at once for waypoints no follower may be sent or a follower
        that is not polled."""
        checked = validate_waypoints(waypoints)
        if follower not in self._membership.followers:
            raise ValueError(f"unknown follower {follower!r}")
        self._inbox.put(partial(self._leader.set_control, follower, checked))

    def observe_urgency(self, follower: str, v: float) -> None:
        """The application's urgency signal for one follower, into its weight's EMA."""
        self._inbox.put(partial(self._leader.observe_urgency, follower, v))

    def close(self) -> None:
        """Stop polling (waits for the poll in flight) and undeclare everything."""
        self._stop.set()
        self._inbox.put(None)
        self._thread.join()
        if self.bridge is not None:
            self.bridge.close()
        self._role.close()
        self._membership.close()
        self._deliveries.close()
        self._stats.close()
        undeclare(self._control)

    def __enter__(self) -> LeaderNode:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # --- the poll thread ---

    def _run(self) -> None:
        leader = self._leader
        try:
            while not self._stop.is_set():
                if self._role.changed:
                    self._take_role()
                if self._role.active:
                    self._poll(self._clock())
                self._hand_on()
                now = self._clock()
                if now >= self._stats.due:  # while the poll just sent is on its way
                    self._publish_stats(now)
                if now >= self._deliveries.due:
                    self._deliveries.flush()
                timer = leader.get_timer()
                wake_at = min(self._stats.due, self._deliveries.due)
                wake_at = wake_at if timer is None else min(timer, wake_at)
                try:
                    self._take(self._inbox.get(timeout=max(0.0, wake_at - now)))
                except queue.Empty:
                    leader.handle_timer(self._clock())
        finally:
            self._hand_on()

    def _hand_on(self) -> None:
        while (event := self._leader.next_event()) is not None:
            self._outlets.hand_on(event)

    def _take(self, arrival: Arrival) -> None:
        """Feed one arrival from the inbox to the core."""
        match arrival:
            case (link, int(poll_seq)):
                self._leader.receive_end(link.follower, poll_seq, self._clock())
            case (link, zenoh.Reply() as reply):
                data = link.payload(reply, self._max_reply, self.bad_input)
                if data is not None:
                    self._leader.receive_reply(link.follower, data, self._clock())
            case None:
                pass
            case command:
                try:
                    command()
                except ValueError as exc:  # a follower that left meanwhile
                    log.info("application call not applied: %s", exc)

    def _poll(self, now: float) -> None:
        """Send the polls the core has (one, or up to ``in_flight``), each with the
        control information when the core says it is due."""
        while (request := self._leader.next_poll(now)) is not None:
            control = request.control
            if control is not None:
                self._control.put(control)
            self._links[request.follower].poll(request.payload, request.poll_seq)

    def _take_role(self) -> None:
        active = self._role.take(self._clock())
        if self._on_role is not None:
            notify(self._on_role, active)

    def _publish_stats(self, now: float) -> None:
        """The stats due by ``now``; at a new round, followers gone long are forgotten
        and an active leader rises above an epoch as high as its own (``hold``)."""
        if self._stats.between_rounds:
            self._membership.forget_departed(self._leader, now)
            if self._role.active:
                self._role.hold(now)
        self._stats.tick(now, self._leader, self._links, bool(self._role.active), self.bridge)
