"""The leader side of the push baselines: receive pushed frames and measure them as the
polling leader measures its deliveries.

Per follower: AoI from the generation time each frame carries (the core's AoITracker:
an older frame never lowers the age), the share of sent frames that arrived (from the
sequence numbers: ``p_hat``, as the polling leader's share of answered polls),
deliveries and throughput. The stats JSON go on the same keys, with the same fields, as
the polling leader's (DESIGN.md section 3), so every tool reads every system alike.
Sender and receiver are taken to share one clock (one host, or synchronised clocks):
there is no poll to estimate an offset from.
"""

from __future__ import annotations

import logging
import selectors
import socket
import threading
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from types import TracebackType

import zenoh

from wiswarm_zenoh.baselines.senders import PUSH_LEAF, parse_address
from wiswarm_zenoh.baselines.stamp import (
    LENGTH,
    MAX_FRAME_BYTES,
    MAX_UDP_PAYLOAD,
    Stamped,
    decode_frame,
    decode_stamp,
)
from wiswarm_zenoh.core import AoITracker, WireError
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.leader_node import STATS_PERIOD
from wiswarm_zenoh.transport.telemetry import LeaderSummary, to_json

log = logging.getLogger(__name__)

KINDS = ("push", "udp", "tcp")
UDP_BUFFER = 8 * 1024 * 1024  # the receiver must not be the bottleneck
SELECT_PERIOD = 0.2  # seconds: how soon the socket threads see close()
FrameCallback = Callable[[Stamped, float], None]  # a fresh frame, when it arrived


@dataclass
class _Follower:
    """What the receiver knows of one sender."""

    aoi: AoITracker
    first_seq: int
    last_seq: int
    received: int = 0
    bytes: int = 0
    errors: int = 0
    started: float = field(default=0.0)

    def record(self, follower: str, now: float) -> dict[str, float | int | str]:
        span = max(now - self.started, 1e-9)
        attempts = self.last_seq - self.first_seq + 1
        return {
            "follower": follower, "aoi_s": self.aoi.age(now), "mean_aoi_s": self.aoi.mean(now),
            "p95_aoi_s": self.aoi.percentile(0.95, now), "peak_aoi_s": self.aoi.peak(now),
            "p_hat": min(1.0, self.received / attempts), "weight": 1.0, "polls": 0,
            "deliveries": self.aoi.deliveries, "timeouts": 0, "errors": self.errors,
            "deliveries_per_s": self.aoi.deliveries / span,
            "throughput_mbps": self.bytes * 8 / span / 1e6,
        }


class Receiver:
    """Receives one baseline's frames (``kind`` push, udp or tcp) until ``close()``.

    ``on_frame(frame, now)`` runs for every frame fresher than
    the last from its follower (on the receiving thread: keep it short). Stats are
    published every ``stats_period`` on the polling leader's keys; ``latest`` holds them.
    """

    def __init__(self, session: zenoh.Session, swarm: str, kind: str, bind: str = "0.0.0.0:7450",
                 *, on_frame: FrameCallback | None = None, clock: Callable[[], float] = time.time,
                 stats_period: float = STATS_PERIOD, label: str | None = None) -> None:
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
        self.keys = SwarmKeys(swarm)
        self.kind = kind
        self.label = label or kind
        self._session = session
        self._on_frame = on_frame
        self._clock = clock
        self._lock = threading.Lock()
        self._followers: dict[str, _Follower] = {}
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._started = clock()
        self._stop = threading.Event()
        self.bad_input = BadInputLog(log)
        self.latest: list[dict[str, float | int | str]] = []
        self.summary = LeaderSummary([], 0.0, 0.0, self.label, 0.0)
        self._entities = ExitStack()
        self._leader_stats = self._entities.enter_context(session.declare_publisher(
            self.keys.leader_stats, encoding=zenoh.Encoding.APPLICATION_JSON))
        self._threads: list[threading.Thread] = []
        if kind == "push":
            self._entities.enter_context(session.declare_subscriber(
                f"{self.keys.prefix}/*/{PUSH_LEAF}", self._on_sample))
        else:
            self._socket = self._bind(kind, bind)
            self._entities.callback(self._socket.close)
            serve = self._serve_udp if kind == "udp" else self._serve_tcp
            self._threads.append(threading.Thread(target=serve, name=f"{kind}-receiver",
                                                  daemon=True))
        self._threads.append(threading.Thread(target=self._publish_loop, args=(stats_period,),
                                              name="baseline-stats", daemon=True))
        for thread in self._threads:
            thread.start()

    @staticmethod
    def _bind(kind: str, bind: str) -> socket.socket:
        host, port = parse_address(bind)
        if kind == "udp":
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, UDP_BUFFER)
        else:
            sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        if kind == "tcp":
            sock.listen()
        sock.settimeout(SELECT_PERIOD)
        return sock

    # --- input ---

    def take(self, frame: Stamped, source: str, now: float) -> None:
        """One frame in: its follower's AoI, sequence and byte counts; ``on_frame``."""
        with self._lock:
            state = self._followers.get(frame.follower)
            if state is None:
                state = _Follower(AoITracker(now), frame.seq, frame.seq, started=now)
                self._followers[frame.follower] = state
            state.received += 1
            state.bytes += len(frame.payload)
            state.first_seq = min(state.first_seq, frame.seq)
            state.last_seq = max(state.last_seq, frame.seq)
            fresh = state.aoi.deliver(frame.generated_at, now)
        if fresh and self._on_frame is not None:
            try:
                self._on_frame(frame, now)
            except Exception:
                log.exception("on_frame failed for a frame from %s", source)

    def _bad(self, source: str, follower: str | None, reason: str) -> None:
        self.bad_input.report(source, reason)
        if follower is not None:
            with self._lock:
                state = self._followers.get(follower)
                if state is not None:
                    state.errors += 1

    def _on_sample(self, sample: zenoh.Sample) -> None:
        now = self._clock()
        key = str(sample.key_expr)
        follower = self.keys.follower_of(key, PUSH_LEAF)
        attachment = sample.attachment
        try:
            if follower is None:
                raise WireError("not a push key")
            generated_at, seq = decode_stamp(b"" if attachment is None else
                                             attachment.to_bytes())
        except WireError as exc:
            self._bad(key, follower, str(exc))
            return
        self.take(Stamped(follower, generated_at, seq, sample.payload.to_bytes()), key, now)

    def _take_bytes(self, data: bytes, source: str) -> None:
        now = self._clock()
        try:
            frame = decode_frame(data)
        except WireError as exc:
            self._bad(source, None, str(exc))
            return
        self.take(frame, source, now)

    def _serve_udp(self) -> None:
        while not self._stop.is_set():
            try:
                data, address = self._socket.recvfrom(MAX_UDP_PAYLOAD + 1)
            except TimeoutError:
                continue
            except OSError:
                return  # closed
            self._take_bytes(data, f"udp {address[0]}:{address[1]}")

    def _serve_tcp(self) -> None:
        selector = selectors.DefaultSelector()
        selector.register(self._socket, selectors.EVENT_READ)
        buffers: dict[socket.socket, tuple[bytearray, str]] = {}
        while not self._stop.is_set():
            for key, _ in selector.select(SELECT_PERIOD):
                sock = key.fileobj
                assert isinstance(sock, socket.socket)
                if sock is self._socket:
                    conn, address = sock.accept()
                    conn.setblocking(False)
                    selector.register(conn, selectors.EVENT_READ)
                    buffers[conn] = (bytearray(), f"tcp {address[0]}:{address[1]}")
                    continue
                buffer, source = buffers[sock]
                try:
                    chunk = sock.recv(1 << 20)
                except OSError:
                    chunk = b""
                if chunk:
                    buffer.extend(chunk)
                if not chunk or not self._frames_from(buffer, source):
                    selector.unregister(sock)
                    sock.close()
                    del buffers[sock]
        for sock in buffers:
            sock.close()
        selector.close()

    def _frames_from(self, buffer: bytearray, source: str) -> bool:
        """Take every whole frame in ``buffer``; False if the stream is garbage (the
        connection is then closed: its framing cannot be trusted any more)."""
        while len(buffer) >= LENGTH.size:
            (size,) = LENGTH.unpack_from(buffer)
            if size > MAX_FRAME_BYTES:
                self._bad(source, None, f"frame length {size} exceeds {MAX_FRAME_BYTES}")
                return False
            if len(buffer) < LENGTH.size + size:
                return True
            self._take_bytes(bytes(buffer[LENGTH.size:LENGTH.size + size]), source)
            del buffer[:LENGTH.size + size]
        return True

    # --- output ---

    def _publish_loop(self, period: float) -> None:
        while not self._stop.wait(period):
            self.publish_stats()

    def publish_stats(self) -> None:
        now = self._clock()
        with self._lock:
            records = [state.record(name, now) for name, state in sorted(self._followers.items())]
        for record in records:
            name = str(record["follower"])
            publisher = self._publishers.get(name)
            if publisher is None:
                publisher = self._entities.enter_context(self._session.declare_publisher(
                    self.keys.stats(name), encoding=zenoh.Encoding.APPLICATION_JSON))
                self._publishers[name] = publisher
            publisher.put(to_json(record))
        self.summary = LeaderSummary.of(records, 0.0, self.label, now - self._started)
        self._leader_stats.put(to_json(self.summary.as_dict()))
        self.latest = records

    def close(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join()
        self._entities.close()

    def __enter__(self) -> Receiver:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
