"""How often a follower's source makes updates, and when a poll of it can find one.

The paper's index ``w p A^2`` assumes a fresh update is always waiting. A camera at
5 Hz polled at 100 Hz answers "nothing new" 19 times in 20: each such poll costs a
round trip, on a radio channel airtime, and removes no age. What a poll at ``t`` can
remove is the age of the freshest delivered update minus the age of the freshest one
waiting: with ``A = t - tau`` and ``z`` the age of the one waiting, the drop of the
quadratic Lyapunov function ``w A^2`` that Max-Weight and the Whittle index maximise
(Kadota et al. 2018; with stochastic arrivals, Kadota and Modiano 2019) is
``w p (A^2 - z^2)``. With ``z = 0`` (a fresh update always waiting) this is the paper's
index exactly; with nothing new (``z = A``) it is 0.

The leader learns ``z`` without anything new on the wire: updates carry their sequence
number and generation time, and the sequence counts every update the source made, so
(generation gap) / (sequence gap) of the updates it takes is the source's mean
interval, whatever the polling rate. A source is *paced* once a poll found it empty
(until then it is taken as always fresh, the paper's assumption: a sensor read on each
poll never is empty, and needs no model). A paced source with interval ``D`` is due
``D`` after its freshest update was generated; before that a poll finds nothing
(``z = A``). Once due, the freshest waiting update was made at the last multiple of
``D`` (``z = A mod D``). A poll that still finds nothing (the source is late, or has
stopped) puts the next try back by a quarter of ``D`` (1 ms while ``D`` is unknown),
doubling with each empty answer in a row, at most ``MAX_BACKOFF``.
"""

from __future__ import annotations

import math
from collections import deque

GAPS = 8  # updates the interval is taken over
PACED_FOR = 64  # answers with an update after its last empty one: then fresh again
FIRST_BACKOFF = 0.25  # of the interval, after the first empty answer in a row
UNKNOWN_BACKOFF = 0.001  # seconds, while the interval is unknown
MAX_BACKOFF = 1.0  # seconds


class SourcePace:
    """One follower's source as its updates show it (sans-I/O: times come in)."""

    __slots__ = ("_gap_sum", "_gaps", "_last", "_seq_sum", "_since_empty", "due", "empties",
                 "interval")

    def __init__(self) -> None:
        self._gaps: deque[tuple[float, int]] = deque()  # (generation gap, sequence gap)
        self._gap_sum, self._seq_sum = 0.0, 0  # their sums, kept as they come and go
        self._last: tuple[int, float] | None = None  # (seq, generated at, follower clock)
        self._since_empty = PACED_FOR  # answers with an update since the last empty one
        self.empties = 0  # empty answers in a row
        self.interval = 0.0  # the source's mean interval, seconds (0: unknown)
        self.due = -math.inf  # leader clock: a poll before this finds nothing (if paced)

    @property
    def paced(self) -> bool:
        """A poll found it empty lately: its pace decides when it is worth a poll."""
        return self._since_empty < PACED_FOR

    def taken(self, update_seq: int, generated_at: float, tau: float) -> None:
        """An update ``update_seq`` made at ``generated_at`` (the follower's clock) was
        taken; ``tau`` is its generation time on the leader's clock."""
        last = self._last
        if last is not None and update_seq > last[0] and generated_at > last[1]:
            gap, seqs = generated_at - last[1], update_seq - last[0]
            self._gaps.append((gap, seqs))
            self._gap_sum += gap
            self._seq_sum += seqs
            if len(self._gaps) > GAPS:
                gone = self._gaps.popleft()
                self._gap_sum -= gone[0]
                self._seq_sum -= gone[1]
            self.interval = self._gap_sum / self._seq_sum
        elif last is not None and update_seq < last[0]:  # the source restarted
            self._gaps.clear()
            self._gap_sum, self._seq_sum = 0.0, 0
            self.interval = 0.0
        self._last = (update_seq, generated_at)
        self._since_empty += 1
        self.empties = 0
        self.due = tau + self.interval

    def empty(self, now: float) -> None:
        """A poll answered at ``now`` (leader clock) found nothing new."""
        self._since_empty = 0
        self.empties += 1
        base = FIRST_BACKOFF * self.interval if self.interval > 0.0 else UNKNOWN_BACKOFF
        self.due = max(self.due, now + min(base * 2.0 ** (self.empties - 1), MAX_BACKOFF))

    def reset(self) -> None:
        """The follower restarted: its sequence starts again."""
        self._last = None
        self.due = -math.inf


def reducible_age(age: float, now: float, due: float, interval: float) -> float:
    """The age a poll at ``now`` can remove, as the index takes it: ``sqrt(A^2 - z^2)``
    (see the module), ``age`` = A for a source that is not paced (``due`` = -inf)."""
    if now < due:
        return 0.0
    if interval <= 0.0 or age <= 0.0:
        return age
    z = age % interval
    return math.sqrt(age * age - z * z)
