"""How long a follower's polls take, how long to wait for one, and what a lost one costs.

The paper waits a fixed 0.3 s for every reply: right for its WiFi round trips, 500 times
a poll on a fast link, where a hung follower then holds the whole swarm 0.3 s per poll.
Here each follower's timeout follows its own answered polls: twice the longest of the
last ``SAMPLES`` (a fragment of a large update, a slow link, a busy host are all in
there), never under ``floor``, never over ``ceiling`` (``--timeout``). A follower not
measured yet (new, or restarted) is judged by the swarm's answered polls instead
(``SwarmPollTimes``: twice the longest of the last ``SAMPLES`` of any follower), and
waits ``ceiling`` only while nobody has answered: a member that never answers costs
one short poll, not the ceiling. While a follower is silent (probed alone, see
``LeaderConfig``), each probe that goes unanswered doubles the next probe's wait up
to ``ceiling``, so a follower that came back on a slower link is found again; its first
answer resets the doubling and brings its duration into the estimate. A reply that comes
after its timeout counts as an answered poll of that duration: the link is slower than
measured (a token bucket's burst made the first polls quick, say), and the next timeout
is long enough for it.
"""

from __future__ import annotations

from collections import deque

SAMPLES = 32  # answered polls the timeout is taken over
MARGIN = 2.0  # times the longest of them
TYPICAL_EMA = 0.9  # smoothing of the swarm's mean answered poll duration


class SwarmPollTimes:
    """The answered polls of every follower: how long a poll of this swarm takes."""

    __slots__ = ("_recent", "typical")

    def __init__(self) -> None:
        self._recent: deque[float] = deque(maxlen=SAMPLES)
        self.typical = 0.0  # mean answered poll duration, any follower (seconds; 0: none)

    def answered(self, duration: float) -> None:
        self._recent.append(duration)
        self.typical = duration if self.typical == 0.0 else \
            TYPICAL_EMA * self.typical + (1.0 - TYPICAL_EMA) * duration

    def base(self, ceiling: float) -> float:
        """The wait its answered polls allow one more (the ceiling before any)."""
        return MARGIN * max(self._recent) if self._recent else ceiling


class PollTiming:
    """Durations of one follower's answered polls, and the timeout they give."""

    __slots__ = ("_base", "_recent", "_sum", "ceiling", "failed_probes", "floor", "swarm",
                 "unanswered")

    def __init__(self, ceiling: float, floor: float, swarm: SwarmPollTimes | None = None) -> None:
        self.ceiling = ceiling
        self.floor = min(floor, ceiling)
        self.swarm = swarm or SwarmPollTimes()
        self.failed_probes = 0
        self.unanswered = 0  # polls in a row that timed out
        self._recent: deque[float] = deque(maxlen=SAMPLES)
        self._sum = 0.0  # of ``_recent``, kept as durations come and go
        self._base = ceiling  # from its own answered polls, kept current

    @property
    def measured(self) -> bool:
        """It answered since it joined (or restarted)."""
        return bool(self._recent)

    @property
    def timeout(self) -> float:
        """How long its next poll may take (read for every poll)."""
        base = self._base if self._recent else \
            min(self.ceiling, max(self.floor, self.swarm.base(self.ceiling)))
        return base if not self.failed_probes else \
            min(self.ceiling, base * 2.0 ** self.failed_probes)

    def answered(self, duration: float) -> None:
        recent = self._recent
        if len(recent) == SAMPLES:
            self._sum -= recent[0]
        recent.append(duration)
        self._sum += duration
        self.swarm.answered(duration)
        self.failed_probes = self.unanswered = 0
        self._base = min(self.ceiling, max(self.floor, MARGIN * max(self._recent)))

    def timed_out(self, silent: bool) -> None:
        """A poll timed out; ``silent``: the follower is being probed alone."""
        self.unanswered += 1
        if silent:
            self.failed_probes += 1

    def reset(self) -> None:
        """The follower restarted: what was measured may not hold."""
        self._recent.clear()
        self._sum = 0.0
        self.failed_probes = self.unanswered = 0
        self._base = self.ceiling

    @property
    def success(self) -> float | None:
        """The mean duration of its answered polls (None before the first)."""
        return self._sum / len(self._recent) if self._recent else None

    def price(self, p: float) -> float:
        """What one of its polls is worth per unit of time, relative to an answered
        one: 1 / (q + (1 - q) K), K = timeout / mean answered duration (the swarm's
        until it answered once): a lost poll costs K answered ones. q is the chance the
        next poll is answered: ``p`` (the caller forgives one loss of the window: one
        timeout among many answers is no verdict), halved for each poll in a row that
        timed out (p over the last W polls is slow to see a follower that just died)."""
        success = self.success or self.swarm.typical
        if success <= 0.0:
            return 1.0
        q = p * 0.5 ** self.unanswered
        return 1.0 / (q + (1.0 - q) * max(self.timeout / success, 1.0))
