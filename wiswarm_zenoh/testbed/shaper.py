"""The user-space shared link: per direction, one token bucket and one FIFO that the
bytes of every relayed connection wait in, as ``tc tbf rate R burst B latency Q`` holds
the packets of every flow on its interface; one thread per direction lets them out.

A chunk (one read of a connection's socket) joins the tail of its direction's FIFO, and
leaves when it is at the head and the bucket holds its wire size: its bytes plus the
Ethernet, IP and TCP headers of the MSS-sized packets it would cross a 1500-byte-MTU
link in, which is what tbf counts. Chunks are at most half the burst, so every one fits
the bucket. Leaving, it is handed to its connection's writer (``deliver``), in order.

The FIFO holds at most tbf's limit, ``R Q + B`` bytes. A chunk that does not fit waits
in its reader, which stops reading: **backpressure, not tail drop**. A relay cannot drop
bytes of a TCP stream; the sender's TCP meets flow control instead of losses, so its
excess waits in its own socket buffer rather than being dropped and sent again. What it
does not emulate: loss of any kind, contention or collisions (one queue, served in
arrival order), propagation delay (the relay adds its own fixed delay, if any).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from wiswarm_zenoh.sim.link import ETHERNET_HEADER
from wiswarm_zenoh.sim.phy import IP_HEADER, TCP_HEADER
from wiswarm_zenoh.testbed.spec import MTU, ChannelSpec, LinkCounters
from wiswarm_zenoh.token_bucket import TokenBucket
from wiswarm_zenoh.units import format_rate

log = logging.getLogger(__name__)

MSS = MTU - IP_HEADER - TCP_HEADER  # a full TCP segment's payload on the emulated link
PACKET_HEADERS = ETHERNET_HEADER + IP_HEADER + TCP_HEADER  # what tbf counts beyond it
MAX_CHUNK = 16 * 1024  # the most one read takes: 6.6 ms at 20 Mbit/s, so flows interleave


def wire_bytes(payload: int) -> int:
    """What ``payload`` bytes of a TCP stream weigh in tbf's bucket: theirs and the
    headers of the MSS-sized packets they fill."""
    return payload + PACKET_HEADERS * math.ceil(payload / MSS)


def chunk_bytes(burst_bytes: int) -> int:
    """The most a reader takes at once: MAX_CHUNK, or half the burst, whose wire size
    then always fits the bucket (headers weigh well under the other half)."""
    return min(MAX_CHUNK, burst_bytes // 2)


@dataclass
class _Chunk:
    size: int  # its wire size
    deliver: Callable[[], None]
    cancelled: Callable[[], bool]


class Shaper:
    """One direction: a bucket of ``burst_bytes`` filling at ``rate_bps`` in front of a
    FIFO of at most ``limit_bytes``, served by its own thread."""

    def __init__(self, name: str, rate_bps: int, limit_bytes: int, burst_bytes: int,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if limit_bytes < burst_bytes:
            raise ValueError(f"limit_bytes {limit_bytes} must hold the burst, {burst_bytes}")
        self.name, self.limit, self._clock = name, limit_bytes, clock
        self.chunk = chunk_bytes(burst_bytes)
        self._bucket = TokenBucket(rate_bps / 8, burst_bytes, clock())
        self._cond = threading.Condition()
        self._fifo: deque[_Chunk] = deque()
        self._backlog = 0
        self._stopping = False
        self._counters = LinkCounters(0, 0, 0, 0, 0)
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        self._thread = threading.Thread(target=self._serve, name=f"delay-relay {self.name}",
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Drop what is queued, wake every waiting reader, join the thread."""
        with self._cond:
            self._stopping = True
            self._fifo.clear()
            self._backlog = 0
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join()

    def put(self, payload: int, deliver: Callable[[], None],
            cancelled: Callable[[], bool]) -> bool:
        """Queue a chunk of ``payload`` bytes (0: an end of stream, weighing nothing) at
        the tail once it fits; False, and nothing queued, if ``cancelled()`` turned true
        or the link stopped first (``wake`` makes a waiting caller look again)."""
        size = wire_bytes(payload)
        with self._cond:
            self._cond.wait_for(lambda: self._stopping or cancelled()
                                or self._backlog + size <= self.limit)
            if self._stopping or cancelled():
                return False
            self._fifo.append(_Chunk(size, deliver, cancelled))
            self._backlog += size
            if len(self._fifo) == 1:
                self._cond.notify_all()  # the server waits for a head
            return True

    def wake(self) -> None:
        """A connection was cancelled: its reader, if waiting for room, gives up."""
        with self._cond:
            self._cond.notify_all()

    def counters(self) -> LinkCounters:
        """tbf's statistics of this direction: wire bytes and chunks let out, drops
        (always 0: backpressure), heads that waited for tokens, the backlog now."""
        with self._cond:
            c = self._counters
            return LinkCounters(c.sent_bytes, c.sent_packets, 0, c.overlimits, self._backlog)

    def _serve(self) -> None:
        while (chunk := self._next()) is not None:
            chunk.deliver()  # outside the lock, in FIFO order: this thread is the only caller

    def _next(self) -> _Chunk | None:
        """Wait until the head may leave (its tokens are there), take it out; None once
        stopped. A cancelled connection's chunks leave at once, taking no tokens."""
        with self._cond:
            waited = False
            while True:
                if self._stopping:
                    return None
                if not self._fifo:
                    self._cond.wait()
                    continue
                head, now = self._fifo[0], self._clock()
                cancelled = head.cancelled()
                wait = 0.0 if cancelled else self._bucket.wait_s(head.size, now)
                if wait > 0:
                    waited = True
                    self._cond.wait(wait)
                    continue
                self._fifo.popleft()
                self._backlog -= head.size
                self._cond.notify_all()  # room for waiting readers
                if cancelled:
                    continue
                self._bucket.take(head.size, now)
                c = self._counters
                self._counters = LinkCounters(c.sent_bytes + head.size, c.sent_packets + 1, 0,
                                              c.overlimits + waited, 0)
                return head


class SharedLink:
    """Both directions of a ``ChannelSpec`` in user space: ``up`` (followers -> leader
    side, the shared uplink) and ``down`` (polls and control), each its own ``Shaper``."""

    def __init__(self, spec: ChannelSpec, clock: Callable[[], float] = time.monotonic) -> None:
        self.spec = spec
        self.up, self.down = (
            Shaper(name, rate, spec.limit_bytes(rate), spec.burst_bytes, clock)
            for name, rate in (("link up", spec.rate_bps), ("link down", spec.down_bps)))

    def start(self) -> None:
        for shaper in (self.up, self.down):
            shaper.start()
        log.info("shared link: %s", describe(self.spec))

    def stop(self) -> None:
        for shaper in (self.up, self.down):
            shaper.stop()

    def wake(self) -> None:
        for shaper in (self.up, self.down):
            shaper.wake()


def describe(spec: ChannelSpec) -> str:
    """One line: what the link is, in tc's terms."""
    return (f"{format_rate(spec.rate_bps)} up, {format_rate(spec.down_bps)} down, "
            f"{spec.queue_s * 1e3:g} ms queue, {spec.burst_bytes} B burst, "
            "one FIFO per direction, backpressure when full")
