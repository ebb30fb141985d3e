"""How many polls to keep out at once, found from what the leader measures
(``LeaderConfig(in_flight="auto")``, ``wiswarm leader --in-flight auto``).

With K polls out and X answered polls a second, each follower is served every N / X
seconds and an update spends K / X seconds between its poll and its delivery (Little's
law), so a follower's mean age is about (N/2 + K) / X. One more poll out pays off only
if it raises X by more than (N/2 + K + 1) / (N/2 + K): across a WAN, where each poll
waits a round trip the link could fill, it nearly doubles X; on a shared radio channel
or any one bottleneck, X stays and the extra poll only queues. So the tuner measures
``J = (N/2 + K) / X`` over a period at K, tries K + 1 (and, above 1, K - 1) for a
period, and keeps whichever is lower: up only when clearly lower (by ``MARGIN``), down
whenever not clearly worse (fewer polls out load the network less). A trial that loses
is tried again after twice as many periods (up to ``MAX_GAP``), so on a shared channel
the trials cost about one period in ``MAX_GAP``; a trial that wins is followed at once
by the next, so K climbs a period at a time. Sans-I/O: the leader tells it each poll's
end with ``now``.
"""

from __future__ import annotations

PERIOD_POLLS = 16  # completed polls a period takes at least
PERIOD_ROUNDS = 6  # and rounds of K (K polls out: answers come K a round trip apart)
PERIOD_S = 0.25  # and seconds
MARGIN = 0.03  # how much lower J must be to keep one more poll out
MAX_GAP = 16  # periods between trials, at most
MOST = 64  # polls out at most


class InFlightTuner:
    """The number of polls to keep out (``limit``), adjusted from measured throughput."""

    __slots__ = ("_answered", "_base_j", "_down_next", "_gap", "_polls", "_settling",
                 "_started", "_trial", "_wait", "limit")

    def __init__(self) -> None:
        self.limit = 1
        self._trial: int | None = None  # the K being tried, if a trial is on
        self._base_j = 0.0  # J at ``limit``, from its last period
        self._gap = 1  # periods to wait before the next trial
        self._wait = 1
        self._down_next = False  # trials alternate up and down (down only above 1)
        self._started: float | None = None
        self._polls = self._answered = 0
        self._settling = 0  # polls sent before K changed, still to end: not measured

    def completed(self, answered: bool, now: float, followers: int) -> None:
        """A poll ended at ``now``, ``answered`` with something (an update or a part of
        one: an answer with nothing new is no throughput), ``followers`` in the swarm."""
        if self._settling:
            self._settling -= 1
            self._started = now
            return
        if self._started is None:
            self._started = now
        self._polls += 1
        self._answered += answered
        elapsed = now - self._started
        k = self.current
        # whole rounds of K: with K out, answers come in bursts of K a round trip apart
        least = max(-(-PERIOD_POLLS // k) * k, PERIOD_ROUNDS * k)
        if self._polls < least or elapsed < PERIOD_S or self._polls % k:
            return
        j = (followers / 2 + k) / max(self._answered / elapsed, 1e-9)
        self._started, self._polls, self._answered = now, 0, 0
        self._end_period(j, followers)
        if self.current != k:
            self._settling = k

    def _end_period(self, j: float, followers: int) -> None:
        trial = self._trial
        if trial is None:
            self._base_j = j
            self._wait -= 1
            if self._wait <= 0:
                self._start_trial(followers)
            return
        self._trial = None
        better = j < self._base_j * (1.0 - MARGIN) if trial > self.limit \
            else j <= self._base_j * (1.0 + MARGIN)
        if better:
            up = trial > self.limit
            self.limit, self._base_j, self._gap = trial, j, 1
            self._down_next = not up
            if up or trial > 1:
                self._start_trial(followers)  # on the same way while it pays
                return
        else:
            self._gap = min(2 * self._gap, MAX_GAP)
        self._wait = self._gap

    def _start_trial(self, followers: int) -> None:
        if self._down_next and self.limit > 1:
            self._trial = self.limit - 1
        elif self.limit < min(followers, MOST):
            self._trial = self.limit + 1
        else:
            self._wait = self._gap
            return
        self._down_next = not self._down_next

    @property
    def current(self) -> int:
        """The polls to keep out now (a trial's K during a trial)."""
        return self._trial or self.limit
