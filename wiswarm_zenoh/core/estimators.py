"""Per-follower estimates the scheduler needs: link reliability and application weight."""

from __future__ import annotations

import math
from collections import deque


class ReliabilityEstimator:
    """``p_hat`` = answered share of the last ``window`` polls (paper: D_i(t) / W).

    Until ``window`` polls were made, the missing ones count as ``prior`` each, so a new
    follower is neither starved (prior 1) nor trusted on one lucky answer. A follower
    that has never answered and misses a poll loses its prior (p = 0: silent, probed
    alone with back-off) until it answers: a member that never gives a valid answer
    (a token with nothing behind it, a hung or garbage-speaking queryable) costs the
    swarm one poll, not ``window`` of them.
    """

    def __init__(self, window: int, prior: float = 1.0) -> None:
        if window < 1:
            raise ValueError(f"window must be an integer >= 1, got {window}")
        if not 0.0 <= prior <= 1.0:
            raise ValueError(f"prior must be in [0, 1], got {prior}")
        self.window = window
        self.prior = prior
        self._outcomes: deque[bool] = deque(maxlen=window)
        self._answered = 0
        self._prior_given = prior
        self.ever_answered = False
        self.value = prior  # kept current by ``record``: the leader reads it on every poll

    def record(self, answered: bool) -> None:
        self.value = self.after(answered)
        if not self.ever_answered:
            self.ever_answered = answered
            self.prior = self._prior_given if answered else 0.0
        if len(self._outcomes) == self.window and self._outcomes[0]:
            self._answered -= 1
        self._outcomes.append(answered)
        self._answered += answered

    def forget_outage(self) -> None:
        """Drop the polls that went unanswered since the last answer: the follower's
        process was gone (it rejoined with a new one), so they measured its absence, not
        its link. One that never answered gets a newcomer's prior back."""
        while self._outcomes and not self._outcomes[-1]:
            self._outcomes.pop()
        if not self.ever_answered:
            self.prior = self._prior_given
        missing = self.window - len(self._outcomes)
        self.value = (self._answered + self.prior * missing) / self.window

    def after(self, answered: bool) -> float:
        """What ``value`` would be with one more poll recorded (nothing changes)."""
        full = len(self._outcomes) == self.window
        count = self._answered - (full and self._outcomes[0]) + answered
        missing = self.window - min(len(self._outcomes) + 1, self.window)
        prior = self.prior if self.ever_answered else self._prior_given * answered
        return (count + prior * missing) / self.window

    @property
    def forgiving(self) -> float:
        """p with one unanswered poll of the window forgiven: what one loss among many
        answers says of the next poll (p over W polls moves by 1/W per loss and keeps it
        for W polls of this follower, tens of seconds in a large swarm)."""
        return min(1.0, self.value + 1.0 / self.window)


class WeightEMA:
    """``w <- alpha w + (1 - alpha) v``: smooths a noisy urgency signal (paper, eq. 3)."""

    def __init__(self, alpha: float = 0.8, initial: float = 1.0) -> None:
        if not 0.0 <= alpha <= 1.0:
            raise ValueError(f"alpha must be in [0, 1], got {alpha}")
        self.alpha = alpha
        self.value = initial

    def observe(self, v: float) -> float:
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"urgency must be a finite number >= 0, got {v!r}")
        self.value = self.alpha * self.value + (1.0 - self.alpha) * v
        return self.value
