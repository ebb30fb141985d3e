"""A TCP relay holding every byte for a fixed delay: the one-way delay of a wide-area
link between Zenoh routers (edge site <-> cloud), which ``tc`` cannot add here (no
``netem``). Given a ``SharedLink`` (``shaper``), it is also the shared bottleneck
without root: every connection's bytes wait in one token bucket and FIFO per direction
before their delay; without one, the link's rate stays ``tbf``'s job.

Design: per connection, a pipe each way with a reader and a writer thread. The reader
stamps each chunk as it reads it and queues it, due ``delay`` later; the writer sleeps
until the oldest chunk is due and writes it at once. Reading never waits for writing, so
the queue holds just the bytes in flight (rate x delay) and a chunk waits for its delay
only: no coalescing, no pacing. Threads, as a timed condition wait wakes within tens of
microseconds (epoll rounds up to ms). TCP_NODELAY: Nagle would hold small chunks back.

Backpressure: a writer whose socket blocks falls behind; once it is ``max_lag`` late, or
its pipe holds ``max_held`` bytes (keep it above rate x delay), the reader stops until it
catches up: the sender meets TCP flow control as on a direct link, not a queue hiding
congestion from Zenoh, and memory stays bounded. Put the relay after the link's tbf,
where bytes come at the link's rate; before it, it takes in what the sender offers for
``delay + max_lag`` (split TCP).

Ends cross like bytes: an EOF read is a shutdown of writing on the other side once due,
a reset read resets both sides once due; a failed write, or ``stop()``, resets both now.
A target that cannot be reached resets (and logs) the accepted connection. Standalone:
``python -m wiswarm_zenoh.testbed.relay --listen HOST:PORT --target HOST:PORT --delay 20ms``
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import logging
import math
import socket
import struct
import sys
import threading
import time
from collections import deque
from collections.abc import Callable

from wiswarm_zenoh.testbed.shaper import Shaper, SharedLink

log = logging.getLogger(__name__)

Address = tuple[str, int]
CHUNK = 128 * 1024  # the most one read takes
DEFAULT_MAX_HELD = 16 * 1024 * 1024  # per direction: 20 ms at 800 MB/s
DEFAULT_MAX_LAG = 0.002
LATE = 0.001  # a chunk written later than this after its due time counts as late
CONNECT_TIMEOUT = 10.0  # s, to reach the target
SEND_STUCK = 0.5  # s a send in progress may take to end once its connection is reset
_LINGER_RESET = struct.pack("ii", 1, 0)  # close() then sends a RST, not a FIN


@dataclasses.dataclass
class RelayCounters:
    """What a relay has carried since it started (bytes count once written)."""

    to_target_bytes: int = 0  # listen side -> target side
    from_target_bytes: int = 0  # target side -> listen side
    connections: int = 0  # accepted, in total
    active: int = 0  # being relayed now
    unreachable: int = 0  # accepted, but the target could not be reached
    chunks: int = 0  # written, both ways
    late_chunks: int = 0  # written more than LATE after their due time
    max_lateness_s: float = 0.0  # the latest a chunk was written after its due time
    peak_held_bytes: int = 0  # the most one direction of one connection held at once


def address_text(address: Address) -> str:
    """``host:port`` (``[v6]:port``), for logs."""
    return f"[{address[0]}]:{address[1]}" if ":" in address[0] else f"{address[0]}:{address[1]}"


class _Pipe:
    """One direction of one connection: a FIFO of (due time, chunk) between a reader and
    a writer thread; chunk b"" is an EOF, None a reset."""

    def __init__(self, conn: _Connection, src: socket.socket, dst: socket.socket,
                 to_target: bool, delay: float, shaper: Shaper | None) -> None:
        self.conn, self.src, self.dst, self.to_target, self.delay = (
            conn, src, dst, to_target, delay)
        self.shaper, self.chunk = shaper, CHUNK if shaper is None else shaper.chunk
        self.cond = threading.Condition()
        self.fifo: deque[tuple[float, bytes | None]] = deque()
        self.held, self.paused = 0, False  # bytes in the FIFO; the reader waits for room
        self.writing_due: float | None = None  # the due time of the chunk being written

    def send_ended(self) -> bool:
        return self.writing_due is None

    def _must_pause(self) -> bool:
        """The writer is behind (its socket blocks), or too much is held."""
        relay = self.conn.relay
        oldest = self.writing_due or (self.fifo[0][0] if self.fifo else None)  # never 0.0
        return self.held >= relay.max_held or (
            oldest is not None and time.monotonic() - oldest > relay.max_lag)

    def read(self) -> None:
        conn = self.conn
        while True:
            with self.cond:
                self.paused = True  # the writer wakes it as it catches up
                self.cond.wait_for(lambda: conn.aborted or not self._must_pause())
                self.paused = False
                if conn.aborted:
                    return
            data: bytes | None = None  # a reset, passed on after the delay
            with contextlib.suppress(OSError):
                data = self.src.recv(self.chunk)
            if self.shaper is None:
                self.arrive(data)
            elif not self.shaper.put(len(data or b""), functools.partial(self.arrive, data),
                                     lambda: conn.aborted):
                return
            if not data:
                return

    def arrive(self, data: bytes | None) -> None:
        """Bytes read (or, over a shared link, let out by it): due ``delay`` from now."""
        due = time.monotonic() + self.delay
        with self.cond:
            if self.conn.aborted:
                return
            if not self.fifo:  # else the writer waits for the head, due first
                self.cond.notify_all()
            self.fifo.append((due, data))
            self.held += len(data or b"")
            self.conn.relay._note(peak_held_bytes=self.held)  # cond, then the relay's lock

    def write(self) -> None:
        conn = self.conn
        while True:
            with self.cond:  # aborted checked, and writing_due set, under cond: abort()
                while not conn.aborted and not (self.fifo and self.fifo[0][0] <= time.monotonic()):
                    self.cond.wait(self.fifo[0][0] - time.monotonic() if self.fifo else None)
                if conn.aborted:
                    return
                due, data = self.fifo.popleft()
                self.writing_due = None if data is None else due  # a send, abort() wakes
            late = time.monotonic() - due
            try:
                if data is None:
                    raise ConnectionResetError("the other side reset the connection")
                self.dst.sendall(data) if data else self.dst.shutdown(socket.SHUT_WR)
            except OSError as exc:
                with self.cond:
                    self.writing_due = None
                    self.cond.notify_all()  # an abort() waiting for this send to end
                if not conn.aborted:
                    log.info("relay %s: %s: resetting both sides", conn.name, exc)
                conn.abort()
                return
            with self.cond:
                self.held -= len(data)
                self.writing_due = None
                if self.paused or conn.aborted:
                    self.cond.notify_all()
            conn.relay._note(**{"to_target_bytes" if self.to_target else "from_target_bytes":
                                len(data)}, chunks=1, late_chunks=late > LATE, max_lateness_s=late)
            if not data:
                return


class _Connection:
    """One relayed connection: two pipes, four threads; the last thread out closes."""

    def __init__(self, relay: DelayRelay, client: socket.socket, upstream: socket.socket,
                 peer: Address) -> None:
        self.relay, self.socks = relay, (client, upstream)
        up, down = (None, None) if relay.link is None else (relay.link.up, relay.link.down)
        self.pipes = (_Pipe(self, client, upstream, True, relay.delay, up),
                      _Pipe(self, upstream, client, False, relay.delay_back, down))
        self.name = f"{address_text(peer)} -> {address_text(relay.target)}"
        self.aborted, self._lock, self._running = False, threading.Lock(), 4  # threads

    def start(self) -> None:
        for pipe in self.pipes:
            for run in (pipe.read, pipe.write):
                self.relay._spawn(f"delay-relay {self.name} {'up' if pipe.to_target else 'down'} "
                                  f"{run.__name__}", functools.partial(self._guarded, run))

    def _guarded(self, run: Callable[[], None]) -> None:
        try:
            run()
        except Exception:
            log.exception("relay %s: unexpected error", self.name)
            self.abort()
        finally:
            with self._lock:
                self._running -= 1
                last = self._running == 0
            if last:
                for sock in self.socks:
                    sock.close()
                with self.relay._idle:
                    self.relay._connections.discard(self)
                    self.relay._idle.notify_all()
                log.info("relay %s: closed", self.name)

    def abort(self) -> None:
        """Reset both sides now: wake every thread (a reader by SHUT_RD, a waiting one by
        notify), drop what is held; the last thread out closes with a RST.

        A send in progress is let end (up to SEND_STUCK): only a shutdown of writing
        wakes one blocked for good, and on a socket whose buffer has room it sends a FIN
        at once, which the peer would read as a clean end before the RST. A send still
        blocked has a full buffer: the FIN waits behind it and the RST drops both."""
        with self._lock:
            if self.aborted:
                return
            self.aborted = True
        for pipe in self.pipes:  # each socket is one pipe's dst
            with pipe.cond:
                pipe.fifo.clear()
                pipe.cond.notify_all()
            with contextlib.suppress(OSError):
                pipe.dst.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, _LINGER_RESET)
                pipe.dst.shutdown(socket.SHUT_RD)
        if self.relay.link is not None:  # a reader waiting for room in the link
            self.relay.link.wake()
        for pipe in self.pipes:
            with pipe.cond:
                stuck = not pipe.cond.wait_for(pipe.send_ended, SEND_STUCK)
            if stuck:
                with contextlib.suppress(OSError):
                    pipe.dst.shutdown(socket.SHUT_WR)


class DelayRelay:
    """Relays each TCP connection made to ``listen`` to ``target``, every byte ``delay``
    seconds late (the way back ``delay_back``, by default the same); with ``link``, every
    connection's bytes first cross that shared link (its ``up`` towards the target).
    ``with DelayRelay(...) as relay`` starts it (``relay.port``: the port bound) and the
    link, and stops both, resetting the connections still open."""

    def __init__(self, listen: Address, target: Address, delay: float, *,
                 delay_back: float | None = None, max_held: int = DEFAULT_MAX_HELD,
                 max_lag: float = DEFAULT_MAX_LAG, link: SharedLink | None = None) -> None:
        delay_back = delay if delay_back is None else delay_back
        if not (0 <= delay < math.inf and 0 <= delay_back < math.inf and max_lag >= 0
                and max_held >= 1):  # max_lag inf: only max_held pauses reading
            raise ValueError(f"need finite delays >= 0, max_lag >= 0, max_held >= 1, got "
                             f"{delay!r}, {delay_back!r}, {max_lag!r}, {max_held!r}")
        self.listen, self.target, self.delay, self.delay_back = listen, target, delay, delay_back
        self.max_held, self.max_lag, self.link = max_held, max_lag, link
        self.port = listen[1]
        self._lock = threading.Lock()
        self._idle = threading.Condition(self._lock)
        self._listener: socket.socket | None = None
        self._stopping = threading.Event()
        self._threads: list[threading.Thread] = []
        self._connections: set[_Connection] = set()
        self._counters = RelayCounters()

    def __enter__(self) -> DelayRelay:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self) -> DelayRelay:
        """Bind and listen (an OSError comes here, to the caller), accept on a thread."""
        if self._listener is not None:
            raise RuntimeError("the relay is started already")
        family = socket.AF_INET6 if ":" in self.listen[0] else socket.AF_INET
        self._listener = socket.create_server(self.listen, family=family, backlog=128)
        self.port = self._listener.getsockname()[1]
        if self.link is not None:
            self.link.start()
        with self._lock:
            self._spawn(f"delay-relay accept :{self.port}", self._accept_loop)
        log.info("relay listening on %s, to %s, %g/%g ms",
                 address_text((self.listen[0], self.port)), address_text(self.target),
                 self.delay * 1e3, self.delay_back * 1e3)
        return self

    def stop(self) -> None:
        """Stop accepting, reset open connections, join every thread (a connection still
        reaching its target: up to CONNECT_TIMEOUT); safe to repeat."""
        with self._lock:
            if self._listener is None or self._stopping.is_set():
                return
            self._stopping.set()  # from now on no thread or connection is added
            connections = list(self._connections)
        with contextlib.suppress(OSError):
            self._listener.shutdown(socket.SHUT_RDWR)  # wakes accept()
        for conn in connections:
            conn.abort()
        if self.link is not None:  # wakes readers waiting for room, drops what waits
            self.link.stop()
        for thread in self._threads:
            thread.join()
        self._listener.close()

    def counters(self) -> RelayCounters:
        with self._lock:
            return dataclasses.replace(self._counters, active=len(self._connections))

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Wait until no connection is being relayed; False if ``timeout`` came first."""
        with self._idle:
            return self._idle.wait_for(lambda: not self._connections, timeout)

    def _spawn(self, name: str, run: Callable[[], None]) -> None:
        """Start a thread that stop() joins (the caller holds ``_lock``)."""
        self._threads = [thread for thread in self._threads if thread.is_alive()]
        self._threads.append(threading.Thread(target=run, name=name, daemon=True))
        self._threads[-1].start()

    def _accept_loop(self) -> None:
        assert self._listener is not None
        while True:
            try:
                client, peer = self._listener.accept()
            except OSError as exc:
                if self._stopping.wait(0.05):  # stopped; else EMFILE and such: no spin
                    return
                log.warning("relay on port %d: accept failed: %s", self.port, exc)
                continue
            with self._lock:
                if self._stopping.is_set():
                    client.close()
                    return
                self._counters.connections += 1
                self._spawn(f"delay-relay connect {address_text(peer)}",
                            functools.partial(self._connect, client, peer))

    def _connect(self, client: socket.socket, peer: Address) -> None:
        """Reach the target for one accepted connection, then relay it."""
        try:
            upstream = socket.create_connection(self.target, timeout=CONNECT_TIMEOUT)
        except OSError as exc:
            log.warning("relay %s -> %s: cannot reach the target (%s): closing the "
                        "connection from %s", address_text((self.listen[0], self.port)),
                        address_text(self.target), exc, address_text(peer))
            self._note(unreachable=1)
            client.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, _LINGER_RESET)
            client.close()  # with a RST: the peer must not take it for a clean end
            return
        upstream.settimeout(None)
        for sock in (client, upstream):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conn = _Connection(self, client, upstream, peer)
        with self._lock:
            if self._stopping.is_set():
                for sock in (client, upstream):
                    sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, _LINGER_RESET)
                    sock.close()
                return
            self._connections.add(conn)
            conn.start()
        log.info("relay %s: open", conn.name)

    def _note(self, **changes: float) -> None:
        """Add to the counters; ``peak_*`` and ``max_*`` keep their maximum instead."""
        with self._lock:
            for name, value in changes.items():
                old = getattr(self._counters, name)
                top = name.startswith(("peak_", "max_"))
                setattr(self._counters, name, max(old, value) if top else old + value)


if __name__ == "__main__":  # as a standalone process: relay_cli's command line
    from wiswarm_zenoh.testbed.relay_cli import main

    sys.exit(main())
