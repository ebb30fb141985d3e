"""The reply path of a steady poll: a poll thread reads the get's own channel.

``benchmarks/bench_reply_paths.py`` chose it: a reply handed over by a Python callback
on Zenoh's thread costs every poll GIL hand-offs between threads, and the end-of-get
callback one more, even after a valid reply, when the end is no news (path B, about
0.8 of the bare get loop); a FIFO channel read by the poll thread is the bare loop's own
path (A): Zenoh's threads run no Python, ``recv`` waits with the GIL released, and the
get's end is the channel's close, for free. It serves a steady poll
(``PollRequest.steady``: the only one out, to a follower that answers in time) while no
other poll thread waits on one: that thread releases the core's lock and blocks in
``recv`` until the reply or the get's end (no queryable: at once), while the leader's
other poll thread keeps the timer and the inbox, so a deadline that passes meanwhile
ends the poll there, and the get stays open to the ceiling: a late reply still reaches
the core and teaches it the link's new pace. Every other poll keeps the callback path
(``FollowerLink.poll``). Replies a steady get brings after its answer (another
queryable's on the same key) are still read, and judged, from its ``lingering`` channel.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

import zenoh

from wiswarm_zenoh.core import Leader, PollRequest
from wiswarm_zenoh.transport.links import FollowerLink

SWEEP_PERIOD = 0.02  # seconds between looks at gets that stayed open after their answer

ReplyTaker = Callable[[FollowerLink, zenoh.Reply], None]
EndTaker = Callable[[FollowerLink, int], None]
# A steady get's reply taken; the next poll's get, if that went out on it first
AnswerTaker = Callable[[FollowerLink, zenoh.Reply], "SteadyGet | None"]


@dataclass(slots=True)
class SteadyGet:
    """A steady poll's get, out: its replies come through ``replies``."""

    link: FollowerLink
    poll_seq: int
    replies: zenoh.Handler[zenoh.Reply]


class SteadyGets:
    """Sends steady polls and waits for their answers (under the core's lock, which it
    lets go while it waits)."""

    def __init__(self, leader: Leader, take_answer: AnswerTaker, take_reply: ReplyTaker,
                 take_end: EndTaker) -> None:
        self._leader = leader
        self._take_answer, self._take_reply, self._take_end = take_answer, take_reply, take_end
        self.busy = False  # a poll thread waits on a steady get (one at a time)
        self.closed = False  # no more steady gets (the leader is closing)
        self._token: zenoh.CancellationToken | None = None  # that get's, for ``close``
        self._lingering: list[tuple[FollowerLink, zenoh.Handler[zenoh.Reply]]] = []
        self.sweep_at = 0.0  # when ``sweep`` is due next

    def send(self, link: FollowerLink, request: PollRequest) -> SteadyGet:
        token = zenoh.CancellationToken()
        self._token, self.busy = token, True
        return SteadyGet(link, request.poll_seq, link.poll_steady(request.payload, token))

    def wait(self, get: SteadyGet, lock: threading.Lock) -> SteadyGet | None:
        """Until the poll is answered (its get then lingers), or its get ends; ``lock``
        (held) is let go while ``recv`` waits. The next poll's get, if it went out on
        the answer before the answer was judged (``take_answer``): to wait on next."""
        link, recv, leader = get.link, get.replies.recv, self._leader
        follower, poll_seq = link.follower, get.poll_seq
        following = None
        try:
            while True:
                lock.release()
                try:
                    reply: zenoh.Reply | None = recv()
                except zenoh.ZError:  # closed: the get is over, no reply can come any more
                    reply = None
                finally:
                    lock.acquire()
                if reply is None:
                    self._take_end(link, poll_seq)
                    return None
                self.busy = False  # a poll sent on this answer may take the steady path
                following = self._take_answer(link, reply)
                if following is not None or not leader.awaits(follower, poll_seq):
                    self._lingering.append((link, get.replies))  # (answered, timed out)
                    return following
                self.busy = True
        finally:
            if following is None:  # (else busy with the following get, and its token)
                self.busy, self._token = False, None

    def sweep(self, now: float) -> None:
        """What came since on the gets answered before (usually: only their end); due
        every ``SWEEP_PERIOD``, not on every poll."""
        lingering = self._lingering
        self.sweep_at = now + SWEEP_PERIOD
        still = []
        for link, replies in lingering:
            try:
                while (reply := replies.try_recv()) is not None:
                    self._take_reply(link, reply)
            except zenoh.ZError:  # closed
                continue
            still.append((link, replies))
        self._lingering = still

    def close(self) -> None:
        """No more steady gets; the one waited on is let go (under the core's lock: a
        poll thread may be in ``recv``, none is sending)."""
        self.closed = True
        token = self._token
        if token is not None:
            token.cancel()  # type: ignore[no-untyped-call]
        self._lingering.clear()
