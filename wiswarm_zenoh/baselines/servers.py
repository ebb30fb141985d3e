"""The sockets a UDP or TCP baseline's receiver listens on, each served by one thread
that hands every whole socket frame on, with the sender's address to blame it on."""

from __future__ import annotations

import contextlib
import logging
import selectors
import socket
import threading
from collections.abc import Callable

from wiswarm_zenoh.baselines.senders import resolve
from wiswarm_zenoh.baselines.stamp import LENGTH, MAX_TCP_LENGTH, MAX_UDP_PAYLOAD
from wiswarm_zenoh.usage import UsageError

log = logging.getLogger(__name__)

DEFAULT_BIND = "0.0.0.0:7450"
UDP_BUFFER = 8 * 1024 * 1024  # bytes: a burst of frames waits here, the receiver is no bottleneck
SELECT_PERIOD = 0.2  # seconds: how soon the thread sees close()
READ_BYTES = 1 << 20
SO_RCVBUFFORCE = 33  # Linux (asm-generic/socket.h); Python's socket module lacks the name
Take = Callable[[bytes, str], None]  # a socket frame, and who sent it ("udp HOST:PORT")
Bad = Callable[[str, str], None]  # who sent garbage, and what is wrong with it


def _listen(kind: str, bind: str) -> socket.socket:
    """A bound socket; an address taken or not ours is the user's to fix (UsageError)."""
    family, where = resolve(bind, socket.SOCK_DGRAM if kind == "udp" else socket.SOCK_STREAM)
    sock = socket.socket(family, socket.SOCK_DGRAM if kind == "udp" else socket.SOCK_STREAM)
    try:
        if kind == "udp":
            # Beyond net.core.rmem_max only with CAP_NET_ADMIN (the testbed runs as root).
            try:
                sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, UDP_BUFFER)
            except OSError:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, UDP_BUFFER)
            log.info("udp receive buffer: %d bytes",
                     sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF))
        else:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(where)
        if kind == "tcp":
            sock.listen()
    except OSError as exc:
        sock.close()
        raise UsageError(f"cannot listen on {bind}: {exc.strerror or exc}") from None
    sock.settimeout(SELECT_PERIOD)
    return sock


def _source(kind: str, address: tuple[str, int]) -> str:
    return f"{kind} {address[0]}:{address[1]}"


class SocketServer:
    """Serves ``kind`` (udp or tcp) on ``bind`` until ``close()``: ``take`` gets every
    whole frame, ``bad`` every stream that cannot be framed (it is then closed)."""

    def __init__(self, kind: str, bind: str, take: Take, bad: Bad) -> None:
        self._socket = _listen(kind, bind)
        self._take = take
        self._bad = bad
        self._stop = threading.Event()
        serve = self._serve_udp if kind == "udp" else self._serve_tcp
        self._thread = threading.Thread(target=serve, name=f"{kind}-receiver", daemon=True)
        self._thread.start()

    def _serve_udp(self) -> None:
        while not self._stop.is_set():
            try:
                data, address = self._socket.recvfrom(MAX_UDP_PAYLOAD + 1)
            except TimeoutError:
                continue
            self._take(data, _source("udp", address))

    def _serve_tcp(self) -> None:
        with selectors.DefaultSelector() as selector:
            selector.register(self._socket, selectors.EVENT_READ)
            streams: dict[socket.socket, tuple[bytearray, str]] = {}
            while not self._stop.is_set():
                for key, _ in selector.select(SELECT_PERIOD):
                    sock = key.fileobj
                    assert isinstance(sock, socket.socket)
                    if sock is self._socket:
                        self._accept(selector, streams)
                    elif not self._read(sock, *streams[sock]):
                        selector.unregister(sock)
                        sock.close()
                        del streams[sock]
            for sock in streams:
                sock.close()

    def _accept(self, selector: selectors.BaseSelector,
                streams: dict[socket.socket, tuple[bytearray, str]]) -> None:
        try:
            conn, address = self._socket.accept()
        except OSError as exc:  # the peer gave up already, or out of descriptors
            log.warning("tcp: accept failed: %s", exc)
            return
        conn.setblocking(False)
        selector.register(conn, selectors.EVENT_READ)
        streams[conn] = (bytearray(), _source("tcp", address))
        log.info("%s: connected", streams[conn][1])

    def _read(self, sock: socket.socket, buffer: bytearray, source: str) -> bool:
        """Take what came; False when the stream is over (closed, or garbage: its framing
        cannot be trusted any more)."""
        try:
            chunk = sock.recv(READ_BYTES)
        except OSError as exc:
            chunk = b""
            log.info("%s: %s", source, exc)
        if not chunk:
            log.info("%s: closed%s", source, " inside a frame" if buffer else "")
            return False
        buffer.extend(chunk)
        start = 0
        while len(buffer) - start >= LENGTH.size:
            (size,) = LENGTH.unpack_from(buffer, start)
            if size > MAX_TCP_LENGTH:
                self._bad(source, f"frame length {size} exceeds {MAX_TCP_LENGTH}: closing")
                return False
            end = start + LENGTH.size + size
            if len(buffer) < end:
                break
            self._take(bytes(buffer[start + LENGTH.size:end]), source)
            start = end
        del buffer[:start]
        return True

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        with contextlib.suppress(OSError):
            self._socket.close()
