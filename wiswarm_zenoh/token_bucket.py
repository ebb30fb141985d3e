"""A token bucket as ``tc tbf`` keeps one: ``burst`` bytes of tokens filling at a rate,
full at the start; a packet may leave once the bucket holds its length.

Plain arithmetic on the ``now`` it is given (no clock), so the simulator's ``link``
channel (virtual time) and the user-space shared link (``time.monotonic``) take their
packets out of the same bucket.
"""

from __future__ import annotations

import math


class TokenBucket:
    """``burst`` bytes of tokens filling at ``bytes_per_s``, full at ``now``."""

    __slots__ = ("_stamp", "_tokens", "burst", "bytes_per_s")

    def __init__(self, bytes_per_s: float, burst: float, now: float = 0.0) -> None:
        if not (math.isfinite(bytes_per_s) and bytes_per_s > 0
                and math.isfinite(burst) and burst > 0):
            raise ValueError(f"need a finite rate and burst > 0, got {bytes_per_s!r}, {burst!r}")
        self.bytes_per_s = bytes_per_s
        self.burst = float(burst)
        self._tokens = self.burst
        self._stamp = now

    def refill(self, now: float) -> float:
        """The tokens held at ``now`` (never more than ``burst``)."""
        self._tokens = min(self.burst, self._tokens + (now - self._stamp) * self.bytes_per_s)
        self._stamp = now
        return self._tokens

    def wait_s(self, size: float, now: float) -> float:
        """Seconds from ``now`` until the bucket holds ``size`` bytes (0: it does now)."""
        return max(size - self.refill(now), 0.0) / self.bytes_per_s

    def take(self, size: float, now: float) -> None:
        """``size`` bytes leave at ``now`` (their tokens are there, up to rounding)."""
        self._tokens = max(self.refill(now) - size, 0.0)
