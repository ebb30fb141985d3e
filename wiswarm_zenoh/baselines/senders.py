"""The follower side of the push baselines: frames taken at a fixed rate into a FIFO,
sent in order by a thread, over Zenoh ``put``, plain UDP or plain TCP.

One queueing design for all three, so that they differ only in transport: a frame is
stamped (generation time, sequence) when the camera takes it and enters a bounded FIFO
(tail drop when full, as the tracking demo's push baseline always did); a sender thread
takes frames in order and blocks while the transport does (Zenoh's BLOCK congestion
control, a full TCP send buffer, a UDP socket buffer full of packets still queued in
the kernel). Nobody schedules who talks: that is what is being compared.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import socket
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from contextlib import ExitStack

import zenoh

from wiswarm_zenoh.baselines.stamp import LENGTH, STAMP, encode_frame
from wiswarm_zenoh.transport.keys import SwarmKeys, check_follower

log = logging.getLogger(__name__)

PUSH_LEAF = "push"
CONGESTION = {"block": zenoh.CongestionControl.BLOCK, "drop": zenoh.CongestionControl.DROP}
DEFAULT_CAPACITY = 64  # frames in the FIFO (the tracking demo's push baseline)
CLOSE_WAIT = 2.0  # seconds for the sender thread to finish its frame on close
RECONNECT_MAX = 2.0  # seconds between TCP reconnection attempts, at most


def push_key(keys: SwarmKeys, follower: str) -> str:
    return f"{keys.prefix}/{check_follower(follower)}/{PUSH_LEAF}"


def parse_address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` -> (host, port); ValueError says what is wrong."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"address {text!r} must look like HOST:PORT")
    return host.strip("[]"), int(port)


class FrameFifo:
    """``offer`` stamps a frame and queues it (False if the FIFO is full); a thread
    hands queued frames, in order, to ``send(payload, generated_at, seq)``."""

    def __init__(self, name: str, send: Callable[[bytes, float, int], None],
                 capacity: int = DEFAULT_CAPACITY, clock: Callable[[], float] = time.time
                 ) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.offered = 0
        self.dropped = 0
        self.sent = 0
        self._send = send
        self._clock = clock
        self._fifo: queue.Queue[tuple[bytes, float, int] | None] = queue.Queue(capacity)
        self._thread = threading.Thread(target=self._run, name=f"push-{name}", daemon=True)
        self._thread.start()

    def offer(self, payload: bytes) -> bool:
        self.offered += 1
        try:
            self._fifo.put_nowait((payload, self._clock(), self.offered))
        except queue.Full:
            self.dropped += 1
            return False
        return True

    def _run(self) -> None:
        while (item := self._fifo.get()) is not None:
            try:
                self._send(*item)
            except Exception:  # a transport error costs this frame, not the sender
                log.exception("%s: a frame could not be sent", self._thread.name)
                continue
            self.sent += 1

    def close(self) -> None:
        """Stop: frames still queued are dropped (a send blocked on a congested or dead
        path must not hold the process), the sender thread is given CLOSE_WAIT to end."""
        with contextlib.suppress(queue.Empty):
            while True:
                self._fifo.get_nowait()
        self._fifo.put(None)
        self._thread.join(CLOSE_WAIT)


class FifoSender(ABC):
    """A FIFO of stamped frames in front of a transport: subclasses send one frame
    (``_send``) and let go of the transport (``_release``)."""

    def __init__(self, name: str, capacity: int, clock: Callable[[], float]) -> None:
        self.fifo = FrameFifo(name, self._send, capacity, clock)

    def offer(self, payload: bytes) -> bool:
        """Queue a frame stamped now; False if the FIFO is full (the frame is dropped)."""
        return self.fifo.offer(payload)

    @abstractmethod
    def _send(self, payload: bytes, generated_at: float, seq: int) -> None: ...

    @abstractmethod
    def _release(self) -> None: ...

    def close(self) -> None:
        self.fifo.close()
        self._release()


class PushSender(FifoSender):
    """Zenoh ``put`` on ``wiswarm/<swarm>/<id>/push``, the ``<dQ`` stamp as attachment.
    ``block``: reliable, the put waits while Zenoh's queues are full (the paper's
    WiFi-TCP); ``drop``: Zenoh's default for put, dropped when they are."""

    def __init__(self, session: zenoh.Session, swarm: str, follower: str,
                 congestion: str = "block", capacity: int = DEFAULT_CAPACITY,
                 clock: Callable[[], float] = time.time) -> None:
        if congestion not in CONGESTION:
            raise ValueError(f"congestion must be block or drop, got {congestion!r}")
        self.key = push_key(SwarmKeys(swarm), follower)
        self._entities = ExitStack()
        self._publisher = self._entities.enter_context(session.declare_publisher(
            self.key, congestion_control=CONGESTION[congestion],
            reliability=zenoh.Reliability.RELIABLE))
        super().__init__(follower, capacity, clock)

    def _send(self, payload: bytes, generated_at: float, seq: int) -> None:
        self._publisher.put(payload, attachment=STAMP.pack(generated_at, seq))

    def _release(self) -> None:
        self._entities.close()


class UdpSender(FifoSender):
    """One datagram per frame to the receiver (the kernel IP-fragments it): the paper's
    best WiFi-UDP setting; a lost fragment loses the frame."""

    def __init__(self, follower: str, receiver: str, capacity: int = DEFAULT_CAPACITY,
                 clock: Callable[[], float] = time.time) -> None:
        self._follower = check_follower(follower)
        self._address = parse_address(receiver)
        self._socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        super().__init__(follower, capacity, clock)

    def _send(self, payload: bytes, generated_at: float, seq: int) -> None:
        try:
            self._socket.sendto(encode_frame(self._follower, generated_at, seq, payload),
                                self._address)
        except OSError as exc:  # ENOBUFS, no route: the frame is lost, as on the air
            log.debug("%s: datagram lost: %s", self._follower, exc)

    def _release(self) -> None:
        self._socket.close()


class TcpSender(FifoSender):
    """One TCP connection to the receiver, length-prefixed frames, TCP_NODELAY; it
    reconnects (with backoff, logged) when the receiver goes away."""

    def __init__(self, follower: str, receiver: str, capacity: int = DEFAULT_CAPACITY,
                 clock: Callable[[], float] = time.time) -> None:
        self._follower = check_follower(follower)
        self._address = parse_address(receiver)
        self._socket: socket.socket | None = None
        self._closed = threading.Event()
        super().__init__(follower, capacity, clock)

    def _connected(self) -> socket.socket:
        wait = 0.05
        while self._socket is None:
            try:
                sock = socket.create_connection(self._address, timeout=5.0)
            except OSError as exc:
                log.warning("%s: cannot reach %s:%d (%s): retrying in %.2f s",
                            self._follower, *self._address, exc, wait)
                if self._closed.wait(wait):
                    raise ConnectionError("closed") from None
                wait = min(2 * wait, RECONNECT_MAX)
                continue
            sock.settimeout(None)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._socket = sock
        return self._socket

    def _send(self, payload: bytes, generated_at: float, seq: int) -> None:
        frame = encode_frame(self._follower, generated_at, seq, payload)
        sock = self._connected()
        try:
            sock.sendall(LENGTH.pack(len(frame)) + frame)
        except OSError as exc:
            log.warning("%s: connection lost (%s): reconnecting", self._follower, exc)
            sock.close()
            self._socket = None

    def close(self) -> None:
        self._closed.set()  # a reconnection in progress gives up
        super().close()

    def _release(self) -> None:
        if self._socket is not None:
            self._socket.close()
