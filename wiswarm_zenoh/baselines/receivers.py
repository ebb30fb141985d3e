"""The leader side of the push baselines: receive pushed frames and measure them as the
polling leader measures its deliveries (``tally.py``), on the same keys.

Followers are known as the polling leader knows them, by their liveliness tokens (a
baseline follower declares one too): AoI counts from the join, and a follower that
leaves is forgotten. A frame that arrives is delivered all the same, token or not: on a
congested channel a follower's session may lose its router (its lease runs out behind
the frames) while its frames still arrive, and those must count. A frame from a
follower with no token counts from its arrival.
The stats JSON go on ``wiswarm/<swarm>/<follower>/stats`` and ``.../leader/stats`` with
the polling leader's fields, at its STATS_PERIOD, so every tool reads every system
alike; the leader's ``policy`` names the system (push-block, push-drop, udp, tcp).
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from collections.abc import Callable
from contextlib import ExitStack
from types import TracebackType

import zenoh

from wiswarm_zenoh.baselines.servers import DEFAULT_BIND, SocketServer
from wiswarm_zenoh.baselines.stamp import (
    PUSH_LEAF,
    Stamped,
    decode_frame,
    decode_stamp,
)
from wiswarm_zenoh.baselines.tally import FollowerTally
from wiswarm_zenoh.core import AoITracker, WireError
from wiswarm_zenoh.programs.delivery_csv import DeliveryRecord
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.discovery import Discovery
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.stats_rounds import STATS_PERIOD
from wiswarm_zenoh.transport.telemetry import LeaderSummary, to_json

log = logging.getLogger(__name__)

SYSTEMS = ("push", "udp", "tcp")
# One clock is assumed; a stamp further ahead of it would hold every later frame stale.
MAX_CLOCK_AHEAD = 1.0  # seconds
FrameCallback = Callable[[str, bytes, float, float], object]  # follower, payload, generated, now
PUSH_LABELS = (("push-block", zenoh.CongestionControl.BLOCK),  # (not hashable: no dict)
               ("push-drop", zenoh.CongestionControl.DROP))


class Receiver:
    """Receives one baseline's frames (``system`` push, udp or tcp; udp and tcp listen
    on ``bind``) until ``close()``.

    For every frame fresher than the last from its follower, ``record`` gets a row and
    ``on_frame(follower, payload, generated_at, now)`` runs (on the receiving thread:
    keep it short), as the polling leader's ``on_delivery``. ``latest`` and ``summary``
    hold the stats last published.
    """

    def __init__(self, session: zenoh.Session, swarm: str, system: str,
                 bind: str = DEFAULT_BIND, *, on_frame: FrameCallback | None = None,
                 record: DeliveryRecord | None = None, clock: Callable[[], float] = time.time,
                 stats_period: float = STATS_PERIOD) -> None:
        if system not in SYSTEMS:
            raise ValueError(f"system must be one of {', '.join(SYSTEMS)}, got {system!r}")
        self.keys = SwarmKeys(swarm)
        self.system = system
        self.bad_input = BadInputLog(log)
        self.latest: list[dict[str, float | int | str]] = []
        self.summary = LeaderSummary([], 0.0, 0.0, system, 0.0)
        self._session = session
        self._on_frame = on_frame
        self._record = record
        self._clock = clock
        self._started = clock()
        self._lock = threading.Lock()  # the tallies, between the receiving threads
        self._tallies: dict[str, FollowerTally] = {}
        self._errors: Counter[str] = Counter()
        self._sources: dict[str, str] = {}  # sender address -> follower, to blame garbage on
        self._modes: set[str] = set()  # PUSH_LABELS of the push samples seen
        self._stats_lock = threading.Lock()  # publish_stats, between its callers
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._stop = threading.Event()
        self._entities = ExitStack()
        try:
            self._leader_stats = self._entities.enter_context(session.declare_publisher(
                self.keys.leader_stats, encoding=zenoh.Encoding.APPLICATION_JSON))
            self._entities.callback(self._undeclare_stats)
            members = Discovery(session, self.keys.members, self._on_member, "follower token")
            self._entities.callback(members.close)
            if system == "push":
                self._entities.enter_context(session.declare_subscriber(
                    f"{self.keys.prefix}/*/{PUSH_LEAF}", self._on_sample))
            else:
                server = SocketServer(system, bind, self._on_bytes, self._bad)
                self._entities.callback(server.close)
            thread = threading.Thread(target=self._publish_loop, args=(stats_period,),
                                      name="baseline-stats", daemon=True)
            thread.start()
            self._entities.callback(thread.join)
            self._entities.callback(self._stop.set)
        except BaseException:
            self._entities.close()
            raise

    # --- input (Zenoh's and the socket server's threads) ---

    def _on_member(self, key: str, joined: bool) -> None:
        now = self._clock()
        follower = self.keys.follower_of(key, "members")
        if follower is None:
            self.bad_input.report(key, "not a valid member key")
            return
        with self._lock:
            if joined:
                self._tally(follower, now)
            else:
                self._tallies.pop(follower, None)
                self._errors.pop(follower, None)
        log.info("follower %s %s", follower,
                 "joined" if joined else "left")

    def _on_sample(self, sample: zenoh.Sample) -> None:
        now, key = self._clock(), str(sample.key_expr)
        follower = self.keys.follower_of(key, PUSH_LEAF)
        attachment = sample.attachment
        try:
            if follower is None:
                raise WireError("not a follower's push key")
            generated_at, seq = decode_stamp(b"" if attachment is None else
                                             attachment.to_bytes())
        except WireError as exc:
            self._bad(key, str(exc), follower)
            return
        label = next((name for name, control in PUSH_LABELS
                      if control == sample.congestion_control), self.system)
        with self._lock:
            self._modes.add(label)
        self._take(Stamped(follower, generated_at, seq, sample.payload.to_bytes()), key, now)

    def _on_bytes(self, data: bytes, source: str) -> None:
        now = self._clock()
        try:
            frame = decode_frame(data)
        except WireError as exc:
            self._bad(source, str(exc), self._sources.get(source))
            return
        self._sources[source] = frame.follower
        self._take(frame, source, now)

    def _bad(self, source: str, reason: str, follower: str | None = None) -> None:
        """Malformed input: logged with its sender, counted to its follower if known."""
        self.bad_input.report(source, reason)
        if follower is not None:
            with self._lock:
                self._errors[follower] += 1

    def _tally(self, follower: str, now: float) -> FollowerTally:
        """The follower's tally, begun now if it is new (call with the lock held)."""
        tally = self._tallies.get(follower)
        if tally is None:
            tally = self._tallies[follower] = FollowerTally(AoITracker(now))
        return tally

    def _take(self, frame: Stamped, source: str, now: float) -> None:
        ahead = frame.generated_at - now
        if ahead > MAX_CLOCK_AHEAD:
            self._bad(source, f"generated {ahead:.3f} s ahead of the receiver's clock (the "
                      "baselines take one clock: synchronise the hosts)", frame.follower)
            return
        with self._lock:
            tally = self._tally(frame.follower, now)
            fresh = tally.take(frame.generated_at, frame.seq, len(frame.payload), now)
            if fresh and self._record is not None:
                self._record.row(frame.follower, frame.seq, frame.generated_at, now,
                                 len(frame.payload))
        if fresh and self._on_frame is not None:
            try:
                self._on_frame(frame.follower, frame.payload, frame.generated_at, now)
            except Exception:
                log.exception("on_frame failed on a frame from %s", source)

    # --- output ---

    @property
    def label(self) -> str:
        """The system as the leader stats name it: push's congestion control is read off
        the samples (push-block, push-drop; push if none came yet, or both)."""
        with self._lock:
            return next(iter(self._modes)) if len(self._modes) == 1 else self.system

    def _publish_loop(self, period: float) -> None:
        while not self._stop.wait(period):
            self.publish_stats()

    def publish_stats(self) -> None:
        """Put every follower's stats and the leader's now (done every ``stats_period``)."""
        with self._stats_lock:
            now = self._clock()
            with self._lock:
                figures = [(tally.stats(name, self._errors[name], now), tally.extras(now))
                           for name, tally in sorted(self._tallies.items())]
            records = [{**stats.as_dict(), **extras} for stats, extras in figures]
            for record in records:
                name = str(record["follower"])
                if name not in self._publishers:
                    self._publishers[name] = self._session.declare_publisher(
                        self.keys.stats(name), encoding=zenoh.Encoding.APPLICATION_JSON)
                self._publishers[name].put(to_json(record))
            for gone in set(self._publishers) - {str(r["follower"]) for r in records}:
                undeclare(self._publishers.pop(gone))
            summary = LeaderSummary.of({stats.follower: stats.mean_aoi_s for stats, _ in figures
                                        if stats.present}, 0.0, self.label,
                                       now - self._started)
            self._leader_stats.put(to_json(summary.as_dict()))
            self.latest, self.summary = records, summary

    def _undeclare_stats(self) -> None:
        with self._stats_lock:
            undeclare(*self._publishers.values())
            self._publishers.clear()

    def close(self) -> None:
        """Stop receiving and publishing; the last stats stay readable."""
        self._entities.close()

    def __enter__(self) -> Receiver:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
