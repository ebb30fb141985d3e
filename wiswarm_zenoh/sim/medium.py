"""One shared 802.11 collision domain with DCF (CSMA/CA) contention.

Each station has a finite FIFO MAC queue. The medium counts idle backoff slots with a
single counter that only advances while the medium is idle, so a station's frozen
backoff is simply an absolute slot target: the station with the smallest target sends
next, and equal targets collide. One event starts a transmission and one ends it, no
matter how many stations contend. Simplifications, stated: one collision domain (no
hidden stations, no capture), EIFS after a failure taken equal to the ACK wait, and a
frame that finds the medium idle for DIFS with no backoff pending is sent at once.
"""

from __future__ import annotations

import heapq
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.phy import WifiParams

# Called when an MPDU leaves its queue: (data, delivered, now).
Handler = Callable[[object, bool, float], None]


@dataclass(slots=True)
class Mpdu:
    """A MAC frame: its medium time per attempt, link success probability and outcome hook."""

    busy: float
    p_success: float
    acked: bool
    handler: Handler
    data: object


class Station:
    """A transmitter on the medium: a bounded MAC queue plus its DCF backoff state."""

    __slots__ = ("attempts", "cw", "index", "limit", "name", "post_target", "queue", "queued")

    def __init__(self, name: str, index: int, limit: int, cw_min: int) -> None:
        self.name = name
        self.index = index
        self.limit = limit
        self.queue: deque[Mpdu] = deque()
        self.cw = cw_min
        self.attempts = 0
        self.post_target = -1  # slot at which the last drawn backoff ends
        self.queued = False  # present in the contention heap

    def room(self) -> int:
        """How many more MPDUs the MAC queue accepts."""
        return self.limit - len(self.queue)


class Medium:
    """The shared channel: stations contend, one transmission (or a collision) at a time."""

    def __init__(self, engine: Engine, params: WifiParams) -> None:
        self.engine = engine
        self.params = params
        self.stations: list[Station] = []
        self._heap: list[tuple[int, int, Station]] = []
        self._base = 0  # slot count when the current (or next) idle period starts counting
        self._count_from = 0.0  # time slot counting starts (inf while busy)
        self._scheduled = math.inf
        self._version = 0
        self._ending = False
        self.transmissions = 0  # medium uses: a lone frame or one collision
        self.collisions = 0
        self.attempts = 0  # frames put on the air, colliding ones counted each
        self.collided_attempts = 0
        self.busy_time = 0.0

    def station(self, name: str, limit: int | None = None) -> Station:
        """Add a station with a MAC queue of ``limit`` MPDUs (default from the params)."""
        st = Station(name, len(self.stations), limit or self.params.mac_queue, self.params.cw_min)
        self.stations.append(st)
        return st

    def send(self, st: Station, mpdu: Mpdu) -> bool:
        """Queue an MPDU at a station; False (dropped) if its MAC queue is full."""
        if len(st.queue) >= st.limit:
            return False
        st.queue.append(mpdu)
        if not st.queued:
            self._join(st)
        return True

    def _current_slot(self, now: float) -> int:
        """First slot boundary at or after ``now`` (the frozen count while busy)."""
        if now <= self._count_from:
            return self._base
        return self._base + math.ceil((now - self._count_from) / self.params.slot - 1e-9)

    def _join(self, st: Station) -> None:
        now = self.engine.now
        slot = self._current_slot(now)
        busy = self._count_from == math.inf
        if st.post_target > slot:
            target = st.post_target  # resume the frozen backoff
        elif busy:
            target = slot + self._draw(st)  # medium busy on arrival: back off
        else:
            target = slot  # idle medium and no backoff pending: send at once
        st.queued = True
        heapq.heappush(self._heap, (target, st.index, st))
        if not self._ending:
            self._schedule()

    def _draw(self, st: Station) -> int:
        return int(self.engine.rng.random() * (st.cw + 1))

    def _schedule(self) -> None:
        if not self._heap or self._count_from == math.inf:
            return
        start = self._count_from + (self._heap[0][0] - self._base) * self.params.slot
        start = max(start, self.engine.now)
        if start == self._scheduled:
            return
        self._version += 1
        self._scheduled = start
        self.engine.at(start, partial(self._start, self._version))

    def _start(self, version: int) -> None:
        if version != self._version:
            return
        heap = self._heap
        target, _, first = heapq.heappop(heap)
        senders = [first]
        while heap and heap[0][0] == target:
            senders.append(heapq.heappop(heap)[2])
        self._base = target
        self._count_from = math.inf
        self._scheduled = math.inf
        self.transmissions += 1
        self.attempts += len(senders)
        if len(senders) == 1:
            mpdu = first.queue[0]
            duration = mpdu.busy
            success = self.engine.rng.random() < mpdu.p_success
        else:
            self.collisions += 1
            self.collided_attempts += len(senders)
            duration = max(st.queue[0].busy for st in senders)
            success = False
        self.busy_time += duration
        self.engine.at(self.engine.now + duration, partial(self._end, senders, success))

    def _end(self, senders: list[Station], success: bool) -> None:
        now = self.engine.now
        self._count_from = now + self.params.difs
        self._ending = True
        done = [mpdu for st in senders if (mpdu := self._settle(st, success)) is not None]
        for mpdu in done:
            mpdu.handler(mpdu.data, success, now)
        self._ending = False
        self._schedule()

    def _settle(self, st: Station, success: bool) -> Mpdu | None:
        """Apply one attempt's outcome to a sender; the MPDU if it left the queue."""
        params = self.params
        queue = st.queue
        finished = None
        if success or not queue[0].acked or st.attempts + 1 >= params.max_attempts:
            finished = queue.popleft()
            st.attempts = 0
            st.cw = params.cw_min
        else:
            st.attempts += 1
            st.cw = min(2 * st.cw + 1, params.cw_max)
        st.post_target = self._base + self._draw(st)
        if queue:
            heapq.heappush(self._heap, (st.post_target, st.index, st))
        else:
            st.queued = False
        return finished
