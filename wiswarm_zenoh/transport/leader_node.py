"""The leader on Zenoh: discovery by liveliness, the poll loop, control and telemetry.

One thread owns the loop and keeps exactly one poll in flight: it asks the core whom to
poll, sends the ``get`` through that follower's prepared querier, and hands each reply
to the core as it arrives (the reply channel is read right on this thread, no hop).
The poll is over as soon as the core takes a valid reply, and the loop moves on then:
Zenoh's closing of that ``get`` (the follower's final message) is not waited for; the
``get`` is kept open aside, and whatever else it brings (a second queryable on the
key, say) is handed to the core later, which counts it as stale or rejected. Only if
Zenoh closes the ``get`` with no valid reply (the timeout) is the core told so.

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
import random
import threading
import time
from collections import Counter, deque
from collections.abc import Callable, Sequence
from types import TracebackType
from typing import TypeVar

import zenoh

from wiswarm_zenoh.core import (
    Delivered,
    Event,
    Leader,
    LeaderConfig,
    PollRequest,
    Rejected,
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
Outstanding = tuple[FollowerLink, zenoh.Handler[zenoh.Reply]]  # a poll sent, and its replies

STATS_PERIOD = 0.4  # seconds: the contract asks for at least 2 Hz; stats cost a percentile
CONTROL_PERIOD = 0.1  # seconds between repeats of unchanged control information
ZENOH_TIMEOUT = b"Timeout"  # the error reply Zenoh itself gives a get that timed out
LATE_BATCH = 8  # finished polls whose gets are drained together (and at every stats put)


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
    ``control_period=0`` puts it with every poll.
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
    ) -> None:
        self.keys = SwarmKeys(swarm)
        self._session = session
        self._leader = Leader(config, rng)
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
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._links: dict[str, FollowerLink] = {}
        self._late: list[Outstanding] = []  # gets whose poll is over, still open
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
        self._wake.set()
        self._thread.join()
        self._late.clear()
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
        self._wake.set()

    # --- the poll thread ---

    def _run(self) -> None:
        try:
            out: Outstanding | None = None  # the poll in flight, once sent
            while not self._stop.is_set():
                if self._changes:
                    self._apply_changes()
                now = self._clock()
                if now >= self._next_stats:
                    self._publish_stats(now)
                if out is None:
                    with self._lock:
                        request = self._leader.poll(now)
                        version = self._control_version
                    if request is None:
                        self._settle()
                        self._wake.wait(max(0.0, self._next_stats - now))
                        self._wake.clear()
                        continue
                    out = self._send(request, version, now)
                out = self._await(*out)
        finally:
            self._settle()

    def _send(self, request: PollRequest, version: int, now: float) -> Outstanding:
        """Send a poll (and the control information, when due)."""
        sent_version, sent_at = self._control_sent
        if version != sent_version or now - sent_at >= self._control_period:
            self._control.put(request.control)
            self._control_sent = (version, now)
        link = self._links[request.follower]
        return link, link.querier.get(payload=request.payload)

    def _await(self, link: FollowerLink, replies: zenoh.Handler[zenoh.Reply]) -> Outstanding | None:
        """Hand the poll's replies to the core until one completes it (the get is then
        kept aside, see the module's docstring) or Zenoh closes the get. Returns the
        next poll if the core sent it on the fast path (``reply_and_poll``)."""
        self._settle()  # the last poll's, while this one is on its way
        if len(self._late) >= LATE_BATCH:
            self._drain_late()
        with self._lock:
            self._leader.prepare()
        for reply in replies:
            now = self._clock()
            data = self._payload(link, reply)
            if data is None:
                continue
            with self._lock:
                request = self._leader.reply_and_poll(link.follower, data, now)
                version = self._control_version
            if request is not None:
                self._late.append((link, replies))
                return self._send(request, version, now)
            if self._take(link, data, now):
                self._late.append((link, replies))
                return None
        with self._lock:  # closed with no valid reply: the core counts the poll unanswered
            events = self._leader.finish_poll(self._clock())
        self._dispatch(events)
        return None

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

    def _take(self, link: FollowerLink, data: bytes, now: float) -> bool:
        """Hand one reply to the core; True if it completed the poll in flight."""
        with self._lock:
            events = self._leader.accept_reply(link.follower, data, now)
            done = self._leader.in_flight is None
        if events:
            self._dispatch(events)
        return done

    def _settle(self) -> None:
        """The core's second step for the last reply, and its delivery handed on."""
        with self._lock:
            events = self._leader.settle()
        if events:
            self._dispatch(events)
        if self._delivered:
            self._hand_over()

    def _drain_late(self) -> None:
        """Replies still coming to gets whose poll is over, without waiting for any:
        the core counts them (stale, or rejected if malformed)."""
        open_gets = []
        for link, replies in self._late:
            try:
                while (reply := replies.try_recv()) is not None:
                    if (data := self._payload(link, reply)) is not None:
                        self._take(link, data, self._clock())
            except zenoh.ZError:  # closed: Zenoh has delivered all it will
                continue
            open_gets.append((link, replies))
        self._late = open_gets

    def _dispatch(self, events: list[Event]) -> None:
        """Report bad input now; keep deliveries for ``_hand_over``."""
        for event in events:
            if isinstance(event, Delivered):
                self._delivered.append(event)
            elif isinstance(event, Rejected | Stale):
                self.bad_input.report(self.keys.update(event.follower), event.reason)
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
            if joined:
                if follower not in self._links:
                    self._links[follower] = FollowerLink.open(
                        self._session, self.keys, follower, self.config.timeout
                    )
                log.info("follower %s joined", follower)
                if self._on_join is not None:
                    _notify(self._on_join, follower)
                continue
            link = self._links.pop(follower, None)
            if link is None:
                continue
            link.close()
            self._transport_errors.pop(follower, None)
            log.info("follower %s left", follower)
            if self._on_leave is not None:
                _notify(self._on_leave, follower)

    def _publish_stats(self, now: float) -> None:
        self._drain_late()  # so that the stats count every late reply so far,
        self._settle()  # and the last delivery
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
