"""The reply path of a steady poll: the poll thread reads the get's own channel.

``benchmarks/bench_reply_paths.py`` chose it: a reply handed over by a Python callback
on Zenoh's thread costs every poll GIL hand-offs between threads, and the end-of-get
callback one more, even after a valid reply, when the end is no news (path B, about
0.8 of the bare get loop); a FIFO channel read by the poll thread is the bare loop's
own path (A): Zenoh's threads run no Python, ``recv`` waits with the GIL released, and
the get's end is the channel's close, for free. It serves a steady poll
(``PollRequest.steady``: the only one out, to a follower that answers in time): the poll
thread blocks in ``recv`` until the reply, the get's end (no queryable: at once), or
the deadline, where ``DeadlineWatch`` cancels the get. Every other poll keeps the
callback path (``FollowerLink.poll``), whose get stays open to the ceiling so that a
late reply still teaches. Replies a steady get brings after its answer (another
queryable's on the same key) are still read, and judged, from its ``lingering`` channel.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import zenoh

from wiswarm_zenoh.core import Leader, PollRequest
from wiswarm_zenoh.transport.deadline_watch import DeadlineWatch
from wiswarm_zenoh.transport.links import FollowerLink

SWEEP_PERIOD = 0.02  # seconds between looks at gets that stayed open after their answer

ReplyTaker = Callable[[FollowerLink, zenoh.Reply], None]
EndTaker = Callable[[FollowerLink, int], None]


@dataclass(slots=True)
class SteadyGet:
    """A steady poll's get, out: its replies come through ``replies``."""

    link: FollowerLink
    poll_seq: int
    replies: zenoh.Handler[zenoh.Reply]


class SteadyGets:
    """Sends steady polls and waits for their answers on the poll thread."""

    def __init__(self, leader: Leader, clock: Callable[[], float], take_reply: ReplyTaker,
                 take_end: EndTaker, name: str) -> None:
        self._leader, self._clock = leader, clock
        self._take_reply, self._take_end = take_reply, take_end
        self._watch = DeadlineWatch(clock, name)
        self._lingering: list[tuple[FollowerLink, zenoh.Handler[zenoh.Reply]]] = []
        self._sweep_at = 0.0

    def send(self, link: FollowerLink, request: PollRequest) -> SteadyGet:
        token = zenoh.CancellationToken()
        replies = link.poll_steady(request.payload, token)
        self._watch.watch(request.deadline, token)  # after: a get cancelled first raises
        return SteadyGet(link, request.poll_seq, replies)

    def wait(self, get: SteadyGet) -> None:
        """Until the poll is answered (its get then lingers), its get ends, or its
        deadline cancels the get (the core's timer then ends the poll)."""
        link, replies, leader = get.link, get.replies, self._leader
        recv = replies.recv
        while True:
            try:
                reply = recv()
            except zenoh.ZError:  # closed: the get is over, no reply can come any more
                self._take_end(link, get.poll_seq)
                break
            self._take_reply(link, reply)
            if leader.in_flight is None:  # answered (a refused reply leaves it out)
                self._lingering.append((link, replies))
                break
        self._watch.clear()

    def sweep(self, now: float) -> None:
        """What came since on the gets answered before (usually: only their end)."""
        lingering = self._lingering
        if not lingering or (len(lingering) > 1 and now < self._sweep_at):
            return
        self._sweep_at = now + SWEEP_PERIOD
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
        self._watch.close()
        self._lingering.clear()
