"""The five ways ``bench_reply_paths`` receives a reply and sends the next get (see
its docstring): each a ``Poller`` running the round-robin loop over the queriers."""

from __future__ import annotations

import queue
import threading
from collections.abc import Sequence

import zenoh

POLL = bytes(32)  # the get's payload: about the size of an encoded Poll
STOP_SLACK = 2.0  # seconds past the query timeout a poller may take to stop


class Poller:
    """One way of running the loop: ``start``, read ``polls`` meanwhile, ``stop``."""

    def __init__(self, queriers: Sequence[zenoh.Querier], timeout: float) -> None:
        self.queriers = list(queriers)
        self.timeout = timeout
        self.polls = 0  # gets answered or given up, in order; written by one thread at a time
        self.failed = 0  # gets closed (or waited out) without an ok reply
        self.size = 0  # bytes of the last reply: proof the payload was taken
        self.error: BaseException | None = None
        self.running = True
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        self._thread = threading.Thread(target=self._guarded, name="poller", daemon=True)
        self._thread.start()

    def _guarded(self) -> None:
        try:
            self.loop()
        except BaseException as exc:  # reported by the main thread
            self.error = exc

    def loop(self) -> None:
        raise NotImplementedError

    def stop(self) -> bool:
        """Stop after the get in flight; False if the poller did not stop in time."""
        self.running = False
        assert self._thread is not None
        self._thread.join(self.timeout + STOP_SLACK)
        return not self._thread.is_alive()


class FifoPoller(Poller):
    """A: the default FIFO handler, iterated by the poll thread."""

    def loop(self) -> None:
        queriers, n = self.queriers, len(self.queriers)
        k = 0
        while self.running:
            for reply in queriers[k % n].get(payload=POLL):
                ok = reply.ok
                if ok is not None:
                    self.size = len(ok.payload.to_bytes())
                    break
            else:
                self.failed += 1
            k += 1
            self.polls = k


class QueuePoller(Poller):
    """B, B2, B3, D: a callback puts (tag, reply) into a SimpleQueue the poll thread
    reads; with ``drop``, (tag, None) follows when the get closes (with ``quiet_drop``:
    only for a get that brought no ok reply, the only one whose end is news)."""

    def __init__(self, queriers: Sequence[zenoh.Querier], timeout: float, *, drop: bool,
                 indirect: bool, quiet_drop: bool = False) -> None:
        super().__init__(queriers, timeout)
        self.drop = drop
        self.indirect = indirect
        self.quiet_drop = quiet_drop

    def loop(self) -> None:
        queriers, n = self.queriers, len(self.queriers)
        inbox: queue.SimpleQueue[tuple[int, zenoh.Reply | None]] = queue.SimpleQueue()
        put, take = inbox.put, inbox.get
        wait = self.timeout + 0.2  # a get that never closes (no drop callback: B2)
        drop, indirect, quiet = self.drop, self.indirect, self.quiet_drop
        callback = zenoh.handlers.Callback
        answered = [-1]  # the last tag an ok reply came for (written on Zenoh's thread)
        k = 0
        while self.running:
            tag = k

            def on_reply(reply: zenoh.Reply, tag: int = tag) -> None:
                if reply.ok is not None:
                    answered[0] = tag
                put((tag, reply))

            if drop:
                def on_drop(tag: int = tag) -> None:
                    if not quiet or answered[0] != tag:
                        put((tag, None))

                handler = callback(on_reply, on_drop, indirect=indirect)
            else:
                handler = callback(on_reply, indirect=indirect)
            queriers[k % n].get(handler, payload=POLL)
            while True:
                try:
                    got, reply = take(timeout=wait)
                except queue.Empty:
                    self.failed += 1
                    break
                if got != tag:
                    continue  # an older get's close (or a late reply): skip it
                if reply is None:
                    self.failed += 1  # closed without an ok reply
                    break
                ok = reply.ok
                if ok is not None:
                    self.size = len(ok.payload.to_bytes())
                    break
            k += 1
            self.polls = k


class ChainPoller(Poller):
    """C, C2: the reply callback sends the next get itself, on Zenoh's thread; with
    ``drop``, the drop callback moves the chain on after a get without an ok reply."""

    def __init__(self, queriers: Sequence[zenoh.Querier], timeout: float, *,
                 drop: bool = True) -> None:
        super().__init__(queriers, timeout)
        self.drop = drop
        self._done = threading.Event()
        self._lock = threading.Lock()  # a reply and a timeout's close may race

    def start(self) -> None:
        self._send(0)

    def stop(self) -> bool:
        self.running = False
        return self._done.wait(self.timeout + STOP_SLACK)

    def _send(self, k: int) -> None:
        if not self.running:
            self._done.set()
            return
        settled = False
        lock = self._lock

        def settle() -> bool:
            nonlocal settled
            with lock:
                if settled:
                    return False
                settled = True
                return True

        def on_reply(reply: zenoh.Reply) -> None:
            ok = reply.ok
            if ok is None or not settle():
                return
            self.size = len(ok.payload.to_bytes())
            self.polls = k + 1
            self._send(k + 1)

        def on_drop() -> None:
            if settle():
                self.failed += 1
                self.polls = k + 1
                self._send(k + 1)

        try:
            self.queriers[k % len(self.queriers)].get(
                zenoh.handlers.Callback(on_reply, on_drop, indirect=False) if self.drop
                else zenoh.handlers.Callback(on_reply, indirect=False), payload=POLL)
        except BaseException as exc:  # on Zenoh's thread: keep it for the main thread
            self.error = exc
            self._done.set()
