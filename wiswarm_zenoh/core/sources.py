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

A source never found empty (a 30 Hz camera polled every 84 ms) is not always fresh
either: when the poll reaches it, its freshest frame is on average half an interval,
17 ms, old (a throttled topic's frames leave as they are made, and do not pay that).
Once its interval is known and it makes updates faster than they are taken (the
sequence skips), it is *phased*: every update a poll takes whole tells, on the
follower's clock alone, how old it was when that poll reached the follower, so the
poll's send time less that age is when a poll reaches the follower as an update is
made, on the leader's clock with no clock offset in it (the poll's own way is). Of two
such phases the later is kept, leaking towards the earlier (that is a slower poll's: a
poll aimed at it would come too soon). Add the time an update takes to become takeable
(``lag``, learnt as a range: ``SourcePace._learn_lag``) and that is ``ready``, from
which a poll sent finds the update; the last such time by the send of the poll that
took it (the update taken was ready by then), so that whatever was learnt, a source is
due again an interval after its last poll went out at most. A poll sent at ``t`` finds
the one made at the last ``ready + k D``: ``z = (t - ready) mod D``, and nothing new
before ``ready + D``, when it is due. A source whose interval is unknown, whose every
update is taken, or whose phases do not follow the interval (irregular updates; polls
whose way varies by more than a tenth of it) has ``z = 0``, as before.

The phase also says when: a poll sent just before its source's next update is ready
brings one almost an interval old. The leader holds the poll it picked for a phased
source until that update is ready when what that removes from the follower's age
outweighs what the hold adds to everyone's (``worth_waiting``).
"""

from __future__ import annotations

import math
from collections import deque

GAPS = 8  # updates the interval is taken over
PACED_FOR = 64  # answers with an update after its last empty one: then fresh again
FIRST_BACKOFF = 0.25  # of the interval, after the first empty answer in a row
UNKNOWN_BACKOFF = 0.001  # seconds, while the interval is unknown
MAX_BACKOFF = 1.0  # seconds
ERROR_EMA = 0.8  # smoothing of the phase's error
LEAK = 0.01  # of the interval: how far a phase moves earlier at most per update taken
LAG_WIDTH = 1 / 32  # of the interval: the uncertainty of ``SourcePace.lag`` aimed at
PHASE_TOLERANCE = 0.1  # of the interval: a phase whose mean error is larger is not used
HOLD_SHARE = 0.25  # of a hold, its cost to each follower's mean age (``worth_waiting``)
SHORTEST_HOLD = 0.01  # of the interval: a shorter wait is rounding, well within a poll's way


class SourcePace:
    """One follower's source as its updates show it (sans-I/O: times come in)."""

    __slots__ = ("_arrival", "_error", "_gap_sum", "_gaps", "_last", "_latest", "_seq_sum",
                 "_since_empty", "_soonest", "due", "empties", "interval", "lag", "phased",
                 "ready", "skips")

    def __init__(self) -> None:
        self._gaps: deque[tuple[float, int]] = deque()  # (generation gap, sequence gap)
        self._gap_sum, self._seq_sum = 0.0, 0  # their sums, kept as they come and go
        self._last: tuple[int, float] | None = None  # (seq, generated at, follower clock)
        self._since_empty = PACED_FOR  # answers with an update since the last empty one
        self.empties = 0  # empty answers in a row
        self.interval = 0.0  # the source's mean interval, seconds (0: unknown)
        self.due = -math.inf  # leader clock: a poll before this finds nothing (if paced)
        self.skips = False  # it made more updates than were taken lately
        # how long after it is made an update can be taken: at least ``_latest``, at
        # most ``_soonest``, ``lag`` taken in between (see ``_learn_lag``)
        self._latest, self._soonest, self.lag = -math.inf, math.inf, 0.0
        # leader clock: a poll sent then reached the follower as the last one taken was made
        self._arrival = -math.inf
        self.ready = -math.inf  # leader clock: polls sent from then find the last one taken
        self._error = math.inf  # mean distance of each arrival from the phase before (mod D)
        self.phased = False  # it skips, and ``ready`` and the interval predict its updates

    @property
    def paced(self) -> bool:
        """A poll found it empty lately: its pace decides when it is worth a poll."""
        return self._since_empty < PACED_FOR

    def reached(self, sent_at: float, received_at: float, generated_at: float,
                whole: bool) -> None:
        """A poll sent at ``sent_at`` (leader clock) reached the follower at
        ``received_at`` and took the first fragment of the update made at
        ``generated_at`` (both the follower's clock: no offset between the clocks goes
        in), ``whole`` if that is all of it. The phase is used (``phased``) for updates
        a poll takes whole (a poll held for the next update would otherwise fetch the
        rest of the last), once each falls where the one before and the interval said,
        within ``PHASE_TOLERANCE`` on average: not for a source whose updates come
        irregularly, nor for polls whose way to the follower varies by more."""
        age = received_at - generated_at
        interval = self.interval
        self._learn_lag(age, interval)
        arrival = sent_at - age
        if interval > 0.0 and self._arrival > -math.inf:
            shift = (arrival - self._arrival) % interval  # from the phase before, signed:
            shift -= interval if shift > interval / 2 else 0.0
            self._error = abs(shift) if self._error == math.inf else \
                ERROR_EMA * self._error + (1.0 - ERROR_EMA) * abs(shift)
            # an earlier phase is a slower poll's: the later one kept, leaking towards it
            arrival = max(arrival, arrival - shift - LEAK * interval)
        self._arrival = arrival
        ready = arrival + self.lag
        if interval > 0.0:  # the update taken was ready by the poll's send, the next not
            ready = sent_at - (sent_at - ready) % interval
        self.ready = ready
        self.phased = whole and self.skips and self._error <= PHASE_TOLERANCE * interval

    def _learn_lag(self, age: float, interval: float) -> None:
        """How long after it is made an update can be taken, from an update taken
        ``age`` old by a poll: at most that (it was taken), more than ``age - interval``
        (the next was not there yet). Polls that reach the follower at one phase only (a
        schedule locked to the cameras) leave that wide: ``lag`` is then the middle, so
        that polls held for an update (``worth_waiting``) halve it, whether they take it
        or find it not yet there; once within ``LAG_WIDTH``, the later end. Bounds that
        cross (an update came later than another was taken: the lag grew, or varies, or
        a host stalled) are opened by that width above the upper bound, however far
        they cross: a lag that grew is found a width per update, and an update that came
        late moves ``lag`` by that width, not to its lateness for good (with ``ready``,
        that would hold the source not due, ``reached``, for as long as its host's
        longest stall)."""
        soonest = self._soonest = min(self._soonest, age)
        if interval > 0.0:
            width = LAG_WIDTH * interval
            latest = self._latest = max(self._latest, age - interval)
            if latest >= soonest:
                latest = self._latest = soonest
                soonest = self._soonest = soonest + width
            if soonest - latest > width:
                self.lag = 0.5 * (latest + soonest)
                return
        self.lag = soonest

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
        self.skips = self._seq_sum > len(self._gaps)
        self.phased = self.phased and self.skips
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
        self.due = self.ready = -math.inf
        self._latest, self._soonest, self.lag = -math.inf, math.inf, 0.0
        self._arrival = -math.inf
        self._error = math.inf
        self.phased = self.skips = False


def reducible_age(age: float, now: float, due: float, interval: float,
                  ready: float | None = None) -> float:
    """The age a poll at ``now`` can remove, as the index takes it: ``sqrt(A^2 - z^2)``
    (see the module), ``age`` = A for a source taken as always fresh (``due`` = -inf,
    ``interval`` = 0); ``ready``: a phased source's (due ``ready + interval``; None: the
    freshest update's generation time, ``now - age``, as for a paced one)."""
    if now < due or age <= 0.0:
        return 0.0
    if interval <= 0.0:
        return age
    z = min((age if ready is None else now - ready) % interval, age)
    return math.sqrt(age * age - z * z)


def worth_waiting(now: float, tau: float, ready: float, interval: float, weight: float,
                  swarm_weight: float) -> float:
    """How long to hold a poll of a phased source (see the module): until its next
    update is ready, if the age that removes from the one the poll takes (``z``, for
    the cycle until the follower's next poll; ``weight``: its w p) outweighs what the
    hold adds to every follower's (``swarm_weight``: their weights' sum),
    ``HOLD_SHARE`` of the hold; 0: send it now. One cycle's arithmetic gives half (the
    cycle, and each mean age with it, grows by half the hold) and counts the others'
    phases as independent of this one's, so the hold moves what theirs give by nothing
    on average. A quarter measures better (the simulator at N = 4 to 14, the testbed at
    N = 4): a source polled as its update is ready stays about in phase for more than
    a cycle. Cameras that sample together lose a little (the in-memory link's five:
    3 %): holding for one moves the others' polls off the phase they share."""
    since = now - ready
    wait = interval - since % interval
    if wait < SHORTEST_HOLD * interval:
        return 0.0
    z = since % interval if since >= interval else now - tau  # (nothing newer: all of A)
    return wait if weight * z > HOLD_SHARE * wait * swarm_weight else 0.0
