"""The follower side of the push baselines: frames stamped into the FIFO of ``fifo.py``
(or, newest only, the slot of one of ``newest.py``) and sent over Zenoh ``put``, plain
UDP or plain TCP. Nobody schedules who talks: that is what is being compared with
polling."""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

import zenoh

from wiswarm_zenoh.baselines.fifo import DEFAULT_CAPACITY, FrameFifo
from wiswarm_zenoh.baselines.newest import NEWEST_SEND_BUFFER, NewestPump
from wiswarm_zenoh.baselines.stamp import (
    LENGTH,
    STAMP,
    encode_frame,
    parse_address,
    push_key,
    sender_id,
    udp_frame_limit,
)
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

log = logging.getLogger(__name__)

# block: the paper's WiFi-TCP (reliable, the put waits while Zenoh's queues are full);
# drop: what a plain put does (Zenoh's defaults: dropped when they are full).
CONGESTION: dict[str, dict[str, Any]] = {
    "block": {"congestion_control": zenoh.CongestionControl.BLOCK,
              "reliability": zenoh.Reliability.RELIABLE},
    "drop": {},
}
# Newest only, a frame must wait in the slot, not beneath the put: Zenoh's tx queue of
# data (2 batches of up to 64 KiB by default) down to one, and the TCP send buffer of
# its links (the kernel's, autotuned up to megabytes: dozens of frames) down to
# NEWEST_SEND_BUFFER. The session's --cfg entries come after, and win. Measured on the
# tbf channel (20 Mbit/s, 200 ms queue; N = 4, 50 KB frames at 100 fps, 20 s): mean
# AoI 246 ms with both, 330 ms with Zenoh's two batches, 1180 ms with neither.
NEWEST_ZENOH = ("transport/link/tx/queue/size/data:1",
                f"transport/link/tcp/so_sndbuf:{NEWEST_SEND_BUFFER}")
CONNECT_TIMEOUT = 5.0  # seconds for one TCP connection attempt
RECONNECT_MAX = 0.5  # seconds between TCP connection attempts, at most (a refusal is cheap)


class QueuedSender(ABC):
    """Frames stamped into a FIFO of ``capacity`` (None: newest only, a slot of one) in
    front of a transport: a subclass sends one frame (``_send``) and lets go of the
    transport (``_release``), both on the queue's thread."""

    def __init__(self, name: str, capacity: int | None, clock: Callable[[], float]) -> None:
        self.queue: FrameFifo | NewestPump[bytes] = (
            NewestPump(name, self._send, clock, self._release) if capacity is None
            else FrameFifo(name, self._send, capacity, clock, self._release))

    def offer(self, payload: bytes) -> bool:
        """Queue a frame stamped now; False if it was dropped (a full FIFO)."""
        return self.queue.offer(payload)

    @abstractmethod
    def _send(self, payload: bytes, generated_at: float, seq: int) -> None: ...

    @abstractmethod
    def _release(self) -> None: ...

    def close(self) -> None:
        self.queue.close()


def resolve(address: str, kind: socket.SocketKind) -> tuple[socket.AddressFamily, Any]:
    """``HOST:PORT`` -> the family and socket address to use (IPv4 or IPv6)."""
    host, port = parse_address(address)
    family, _, _, _, where = socket.getaddrinfo(host, port, type=kind)[0]
    return family, where


class PushSender(QueuedSender):
    """Zenoh ``put`` on ``wiswarm/<swarm>/<id>/push``, the ``<dQ`` stamp as attachment.
    Newest only (``capacity`` None), the put blocks: the slot must wait for the path
    (``NEWEST_ZENOH`` keeps the queues under the put small)."""

    def __init__(self, session: zenoh.Session, swarm: str, follower: str,
                 congestion: str = "block", capacity: int | None = DEFAULT_CAPACITY,
                 clock: Callable[[], float] = time.time) -> None:
        if congestion not in CONGESTION:
            raise ValueError(f"congestion must be block or drop, got {congestion!r}")
        if capacity is None and congestion != "block":
            raise ValueError("newest only needs congestion block: a dropped put would "
                             "empty the slot for nothing")
        self.key = push_key(SwarmKeys(swarm), follower)
        self._publisher = session.declare_publisher(self.key, **CONGESTION[congestion])
        super().__init__(follower, capacity, clock)

    @property
    def congestion_control(self) -> zenoh.CongestionControl:
        """What Zenoh does with a put while its queues are full (the publisher's own)."""
        control: zenoh.CongestionControl = self._publisher.congestion_control
        return control

    def _send(self, payload: bytes, generated_at: float, seq: int) -> None:
        self._publisher.put(payload, attachment=STAMP.pack(generated_at, seq))

    def _release(self) -> None:
        undeclare(self._publisher)


class UdpSender(QueuedSender):
    """One datagram per frame to the receiver (the kernel IP-fragments it): the paper's
    best WiFi-UDP setting; a lost fragment loses the frame."""

    def __init__(self, follower: str, receiver: str, capacity: int = DEFAULT_CAPACITY,
                 clock: Callable[[], float] = time.time) -> None:
        self._name = sender_id(follower)
        self.max_frame = udp_frame_limit(follower)
        family, self._address = resolve(receiver, socket.SOCK_DGRAM)
        self._socket = socket.socket(family, socket.SOCK_DGRAM)
        super().__init__(follower, capacity, clock)

    def offer(self, payload: bytes) -> bool:
        if len(payload) > self.max_frame:
            raise ValueError(f"a frame of {len(payload)} bytes does not fit one UDP datagram "
                             f"(at most {self.max_frame})")
        return super().offer(payload)

    def _send(self, payload: bytes, generated_at: float, seq: int) -> None:
        try:
            self._socket.sendto(encode_frame(self._name, generated_at, seq, payload),
                                self._address)
        except OSError as exc:  # ENOBUFS, no route: the frame is lost, as on the air
            log.debug("%s: datagram %d lost: %s", self._name.decode(), seq, exc)

    def _release(self) -> None:
        self._socket.close()


class TcpSender(QueuedSender):
    """One TCP connection to the receiver, length-prefixed frames, TCP_NODELAY; when the
    receiver goes away, the frame being sent is lost and the sender reconnects with
    backoff (logged). ``send_buffer`` sets SO_SNDBUF (None: the kernel's, autotuned up
    to megabytes): newest only, a small one keeps frames waiting in the slot, where a
    newer one replaces them, not in the kernel."""

    def __init__(self, follower: str, receiver: str, capacity: int | None = DEFAULT_CAPACITY,
                 clock: Callable[[], float] = time.time,
                 send_buffer: int | None = None) -> None:
        if send_buffer is not None and send_buffer < 1:
            raise ValueError(f"send_buffer must be >= 1 byte, got {send_buffer}")
        self._send_buffer = send_buffer
        self._name = sender_id(follower)
        self._receiver = receiver
        self._address = parse_address(receiver)
        self._socket: socket.socket | None = None
        self._lock = threading.Lock()  # the socket, between the sender thread and close
        self._closed = threading.Event()
        super().__init__(follower, capacity, clock)

    def _connect(self) -> socket.socket | None:
        """The connection, made (again) if needed; None once closed."""
        if self._socket is not None:
            return self._socket
        wait, attempts = 0.05, 0
        while not self._closed.is_set():
            attempts += 1
            try:
                sock = socket.create_connection(self._address, timeout=CONNECT_TIMEOUT)
            except OSError as exc:
                if attempts == 1:
                    log.warning("%s: cannot reach %s (%s): retrying, every %g s at most",
                                self._name.decode(), self._receiver, exc, RECONNECT_MAX)
                self._closed.wait(wait)
                wait = min(2 * wait, RECONNECT_MAX)
                continue
            sock.settimeout(None)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            if self._send_buffer is not None:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self._send_buffer)
            log.info("%s: connected to %s (attempt %d)", self._name.decode(), self._receiver,
                     attempts)
            with self._lock:
                if self._closed.is_set():
                    sock.close()
                    return None
                self._socket = sock
            return sock
        return None

    def _send(self, payload: bytes, generated_at: float, seq: int) -> None:
        sock = self._connect()
        if sock is None:
            return
        frame = encode_frame(self._name, generated_at, seq, payload)
        try:
            sock.sendall(LENGTH.pack(len(frame)) + frame)
        except OSError as exc:
            if not self._closed.is_set():
                log.warning("%s: connection to %s lost (%s): reconnecting",
                            self._name.decode(), self._receiver, exc)
            with self._lock:
                self._socket = None
            sock.close()

    def close(self) -> None:
        """A send blocked on a receiver that stopped reading is woken by the shutdown."""
        self._closed.set()
        with self._lock:
            if self._socket is not None:
                with contextlib.suppress(OSError):
                    self._socket.shutdown(socket.SHUT_RDWR)
        super().close()

    def _release(self) -> None:
        with self._lock:
            if self._socket is not None:
                self._socket.close()
                self._socket = None
