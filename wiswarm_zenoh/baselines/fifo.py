"""The one queueing design of every push baseline, so that push, UDP and TCP differ only
in transport (the paper's WiFi-UDP/TCP: frames at a fixed rate into a FIFO).

A frame is stamped (generation time, sequence number) when the camera offers it and
enters a bounded FIFO; a full FIFO drops the new frame (tail drop, as the tracking
demo's push baseline always did). A sender thread takes frames in order and blocks while
the transport does (Zenoh's BLOCK congestion control, a full TCP send buffer, a UDP
socket buffer still full of packets queued in the kernel), so a congested path builds
the FIFO up. Sequence numbers go to the frames the FIFO takes: a gap at the receiver is
then a frame that went out and did not arrive, and ``p_hat`` means what it means for a
poll. ``FramePump`` is that sender thread, whatever holds the frames (``newest.py``
holds one: the newest).
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Generic, TypeVar

log = logging.getLogger(__name__)

DEFAULT_CAPACITY = 64  # frames in the FIFO (the tracking demo's push baseline)
CLOSE_WAIT = 2.0  # seconds for the sender thread to finish its frame on close
P = TypeVar("P")  # what a frame carries to the transport: its bytes, or more
Send = Callable[[P, float, int], None]  # payload, generated_at, seq


class FramePump(ABC, Generic[P]):
    """A thread hands the frames ``_next`` gives, one at a time, to ``send(payload,
    generated_at, seq)``, and once closed calls ``release()`` itself: the transport is
    only ever touched by that thread. A Zenoh publisher undeclared from another thread
    while its put still blocks raises ``RuntimeError: Already borrowed`` (and a socket
    closed under a send is no better), so ``close`` never releases it behind the
    thread's back. A subclass sets up what ``_next`` reads before calling ``__init__``
    (which starts the thread)."""

    def __init__(self, name: str, send: Send[P], release: Callable[[], None]) -> None:
        self.sent = 0
        self._send = send
        self._release = release
        self._thread = threading.Thread(target=self._run, name=f"push-{name}", daemon=True)
        self._thread.start()

    @abstractmethod
    def _next(self) -> tuple[P, float, int] | None:
        """The next frame to send, once there is one; None once closed."""

    @abstractmethod
    def _shut(self) -> None:
        """Drop the frames waiting; ``_next`` returns None from now on."""

    @property
    @abstractmethod
    def counts(self) -> str:
        """What became of the frames offered, for the log."""

    def _run(self) -> None:
        while (item := self._next()) is not None:
            try:
                self._send(*item)
            except Exception:  # a transport error costs this frame, not the sender
                log.exception("%s: a frame could not be sent", self._thread.name)
                continue
            self.sent += 1
        try:
            self._release()
        except Exception as exc:  # late, after its session closed: nothing left to free
            log.debug("%s: releasing the transport: %s", self._thread.name, exc)

    def close(self) -> bool:
        """Stop: frames still waiting are dropped (a send blocked on a congested or dead
        path must not hold the process); the sender thread gets CLOSE_WAIT to end and
        release the transport. Returns whether it did (if not, it does both once its send
        returns, e.g. when the session under it closes; call again to wait)."""
        self._shut()
        self._thread.join(CLOSE_WAIT)
        if self._thread.is_alive():  # a saturated run's end: nothing to act on
            log.info("%s: a send still blocked at close is left to end on its own",
                     self._thread.name)
            return False
        return True


class FrameFifo(FramePump[bytes]):
    """``offer`` stamps a frame and queues it (False if the FIFO is full); the pump's
    thread sends queued frames in order."""

    def __init__(self, name: str, send: Send[bytes], capacity: int = DEFAULT_CAPACITY,
                 clock: Callable[[], float] = time.time,
                 release: Callable[[], None] = lambda: None) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.offered = 0
        self.dropped = 0
        self._seq = 0
        self._clock = clock
        self._lock = threading.Lock()  # stamps stay in order whoever offers
        self._fifo: queue.Queue[tuple[bytes, float, int] | None] = queue.Queue(capacity)
        super().__init__(name, send, release)

    def offer(self, payload: bytes) -> bool:
        with self._lock:
            self.offered += 1
            if self._fifo.full():
                self.dropped += 1
                return False
            self._seq += 1
            self._fifo.put_nowait((payload, self._clock(), self._seq))  # only we put
        return True

    def _next(self) -> tuple[bytes, float, int] | None:
        return self._fifo.get()

    def _shut(self) -> None:
        with self._lock:
            with contextlib.suppress(queue.Empty):
                while True:
                    self._fifo.get_nowait()
            self._fifo.put_nowait(None)

    @property
    def counts(self) -> str:
        return (f"{self.offered} frames offered, {self.sent} sent, {self.dropped} dropped "
                "by the full FIFO")
