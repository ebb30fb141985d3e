"""A follower's data from what the robot already publishes (``wiswarm follower --source``,
``Follower(source=...)``): a subscription on the follower's own session whose samples are
offered as updates, so the follower's queue (the freshest, by default) holds the robot's
stream and the leader's polls carry it. Nothing is decoded: the bytes go as they came.

``Feed`` is what every kind of source shares: it offers a sample stamped with its
generation time (never later than its arrival: a clock ahead must not make an update
look fresher than it is), skips a sample older than one already offered (samples that
overtook each other on the way: the queue must never hold an older update in place of a
newer one), counts samples the follower cannot take (larger than its
``max_update_bytes``), says once that it is waiting for the first sample, and warns once
if none came within ``SILENT_AFTER`` seconds: the one line a user with a mistyped topic
or key needs, at the default log level.

``SourceTimes`` puts a source's own stamps on this host's clock (``core.source_clock``):
a source that stamps on a clock of its own (PX4's microseconds since boot, simulated
time, a robot minutes off) would otherwise look decades or minutes stale, and nobody
would know why. What is decided about the source's clock is said in one line: a WARNING
naming the follower and the source when its stamps are mapped or not used."""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import zenoh

from wiswarm_zenoh.core.source_clock import NEAR, NS_PER_S, SourceClock
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.follower_node import FollowerNode

log = logging.getLogger(__name__)
SILENT_AFTER = 10.0  # seconds without a first sample before a warning names the source


class SourceFeed(Protocol):
    """An open source: it feeds a follower until closed, counting the samples it
    offered, those older than one offered before (skipped) and those too large."""

    @property
    def samples(self) -> int: ...

    @property
    def older(self) -> int: ...

    @property
    def oversized(self) -> int: ...

    def close(self) -> None: ...


class Source(Protocol):
    """What a follower serves instead of offered bytes (``ZenohSource``,
    ``wiswarm_zenoh.ros2.Ros2TopicSource``)."""

    def open(self, session: zenoh.Session, node: FollowerNode) -> SourceFeed: ...


class Feed:
    """Offers one source's samples to ``node``; ``what`` names the source in the log,
    ``check`` says how a user checks its name if nothing comes."""

    def __init__(self, node: FollowerNode, what: str, check: str,
                 clock: Callable[[], float] = time.time) -> None:
        self._node, self.what, self._check, self._clock = node, what, check, clock
        self.samples = 0  # offered to the queue (taken or dropped by it)
        self.oversized = 0  # larger than the follower takes: counted, logged once
        self.older = 0  # generated before the newest offered: skipped
        self._newest = -math.inf
        self._lock = threading.Lock()  # Zenoh may call a subscriber on several threads
        log.info("follower %s: waiting for the first sample of %s", node.follower_id, what)
        self._silence = threading.Timer(SILENT_AFTER, self._still_silent)
        self._silence.daemon = True
        self._silence.start()

    def _still_silent(self) -> None:
        if self.samples == 0 and self.oversized == 0:
            log.warning("follower %s: no sample of %s in %.0f s: is the name right? (%s; "
                        "the leader polls this follower and gets nothing until one comes)",
                        self._node.follower_id, self.what, SILENT_AFTER, self._check)

    def now(self) -> float:
        return self._clock()

    def offer(self, payload: bytes, generated_at: float, arrived_at: float) -> None:
        """Queue ``payload`` generated at ``generated_at`` (this host's clock)."""
        generated_at = min(generated_at, arrived_at)
        problem: str | None = None
        with self._lock:
            if generated_at < self._newest:
                self.older += 1
                return
            try:
                self._node.offer(payload, generated_at)
            except ValueError as exc:
                self.oversized += 1
                problem, first = str(exc), self.oversized == 1
            else:
                self.samples += 1
                self._newest = generated_at
                first = self.samples == 1
        if first and problem is not None:
            log.warning("follower %s: a sample of %s is not served: %s (such samples are "
                        "counted, not logged again)", self._node.follower_id, self.what,
                        problem)
        elif first:
            log.info("follower %s: serving %s (first sample, %d bytes)",
                     self._node.follower_id, self.what, len(payload))

    def closed(self) -> None:
        self._silence.cancel()
        log.info("follower %s: %d samples of %s offered, %d too large to serve, %d older "
                 "than one offered before", self._node.follower_id, self.samples, self.what,
                 self.oversized, self.older)


class SourceTimes:
    """One source's raw stamps as ns on this host's clock (``clock``, in seconds), from
    any thread. ``who`` and ``what`` name the follower and the source in the line that
    says what was decided about its clock: INFO for this host's own clock, else a
    WARNING, as every age the leader reports of this source depends on it."""

    def __init__(self, who: str, what: str, clock: Callable[[], float] = time.time) -> None:
        self._who, self._what, self._clock = who, what, clock
        self._source = SourceClock()
        self._lock = threading.Lock()

    def at(self, raw: int) -> int:
        """The generation time (ns since the epoch, this host's clock) of a sample that
        its source stamped ``raw`` and that arrives now."""
        with self._lock:
            stamped = self._source.stamp(raw, round(self._clock() * NS_PER_S))
            notices = []
            while (notice := self._source.next_notice()) is not None:
                notices.append(notice)
        for notice in notices:
            log.log(logging.INFO if notice.kind == NEAR else logging.WARNING, "%s: %s: %s",
                    self._who, self._what, notice.text)
        return stamped


def zenoh_time(timestamp: zenoh.Timestamp | None) -> float | None:
    """A sample's Zenoh timestamp as seconds since the epoch, if it has one."""
    return None if timestamp is None else timestamp.get_time().timestamp()


@dataclass(frozen=True)
class ZenohSource:
    """The samples put on ``key_expr``; each is stamped with its Zenoh timestamp (given
    by the publisher's session or the first router on its way, where timestamping is
    on), else with its arrival."""

    key_expr: str

    def __post_init__(self) -> None:
        try:
            zenoh.KeyExpr(self.key_expr)
        except zenoh.ZError as exc:  # its text ends with where in Zenoh's sources
            why = str(exc).split(" at /")[0]
            raise ValueError(f"not a key expression: {self.key_expr!r} ({why})") from None

    def open(self, session: zenoh.Session, node: FollowerNode) -> KeyFeed:
        """Subscribe on ``session`` and feed ``node`` (the follower does this)."""
        return KeyFeed(session, self.key_expr, node)


class KeyFeed(Feed):
    """A subscriber on a key expression, feeding a follower until ``close()``."""

    def __init__(self, session: zenoh.Session, key_expr: str, node: FollowerNode) -> None:
        super().__init__(node, f"key {key_expr}", "z_sub or zenoh-cli on this key shows "
                         "what is published there")
        self._subscriber = session.declare_subscriber(
            key_expr, zenoh.handlers.Callback(self._on_sample, indirect=False))

    def _on_sample(self, sample: zenoh.Sample) -> None:
        arrived_at = self.now()
        stamped = zenoh_time(sample.timestamp)
        self.offer(sample.payload.to_bytes(), arrived_at if stamped is None else stamped,
                   arrived_at)

    def close(self) -> None:
        undeclare(self._subscriber)
        self.closed()
