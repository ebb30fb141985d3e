"""A source's own stamps on the follower's clock.

A follower takes each sample's generation time from its source (rmw_zenoh's attachment:
nanoseconds since the epoch on the publisher's clock). Not every source keeps that
clock: PX4 stamps with ``hrt_absolute_time()``, microseconds since its boot; a ROS 2
node may run on simulated time; a robot without NTP may be minutes off. Read as they
are, such stamps make the robot look decades or minutes stale (or fresh from the
future), and nobody is told. So a source's clock is judged from its samples before its
stamps are trusted:

- Over a first window (``LEARN_S`` of arrivals and ``LEARN_SAMPLES`` samples) the stamps
  must advance as a clock does in one of ns, µs or ms: their span over the arrivals'
  span within ``RATE_TOLERANCE`` of one tick per unit. If none fits (simulated time at
  2x, a frozen counter, a clock going backwards) they cannot be used: every sample is
  stamped at its arrival, the one time known not to be too old.
- Stamps in ns whose least ``arrival - stamp`` is within ``NEAR_S`` are this host's
  clock (on the robot a sample arrives well within a millisecond of its publish time):
  used as they are.
- Any other clock that fits is mapped as a one-way clock sync does: the offset is the
  least ``arrival - stamp * unit`` over a sliding window (two buckets of ``BUCKET_S``, so
  slow drift is followed), and a sample is stamped ``stamp * unit + offset``, never later
  than its arrival. The least difference is the sample that waited least: its offset is
  the truest, and any other sample's only makes an update look older than it is.

Until the window is over, a sample whose stamp looks like this host's clock keeps it and
any other is stamped at its arrival: never fresher than it is by more than the way from
the publisher. A clock that jumps back (a reboot: a mapped time more than ``JUMP_S``
behind its arrival with its stamp lower than the one before, or every sample that far
behind for ``JUMP_S``) is learnt again, stamped at arrival meanwhile. A sample held up
on the way (the follower stalled) has a stamp still ahead of the one before and is not
taken for a jump.

Each decision is a ``ClockNotice``, popped with ``next_notice`` (the shell logs it):
exactly one per decision, and a clock learnt again that turns out as it was before is
not told twice. No clock is read here: every time comes in as an argument."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

NS_PER_S = 1_000_000_000
NEAR_S = 1.0  # this host's clock: the least arrival - stamp within this, either way
LEARN_S = 1.0  # seconds of arrivals a clock is judged over, at least
LEARN_SAMPLES = 5  # samples a clock is judged over, at least
RATE_TOLERANCE = 0.25  # how far from one tick per unit a clock may advance
BUCKET_S = 10.0  # the offset is the least of two buckets of this many seconds of arrivals
JUMP_S = 1.0  # a mapped time this far behind its arrival is a clock that jumped back
# (symbol, name, ns per tick) of the units a source's stamps may count in
UNITS = (("ns", "nanoseconds", 1), ("µs", "microseconds", 1_000),
         ("ms", "milliseconds", 1_000_000))

LEARNING, NEAR, MAPPED, FALLBACK = "learning", "near", "mapped", "fallback"
RELEARN = "relearn"


@dataclass(frozen=True, slots=True)
class ClockNotice:
    """One decision on a source's clock. ``kind``: ``near`` (stamps used as they are),
    ``mapped`` (onto this host's clock, ``unit`` and ``offset_ns``), ``fallback``
    (stamped at arrival) or ``relearn`` (its clock jumped back); ``text`` says which
    and why, in a sentence a user can act on."""

    kind: str
    text: str
    unit: str = ""
    offset_ns: int = 0


class SourceClock:
    """Maps one source's raw integer stamps onto this host's clock (ns since the epoch);
    ``stamp`` for every sample, ``next_notice`` for what was decided."""

    def __init__(self) -> None:
        self.state = LEARNING
        self._notices: deque[ClockNotice] = deque()
        self._before: tuple[str, str] | None = None  # (kind, unit) of the last decision
        self._tick = 1  # ns per tick of the unit decided
        self._unit = ""
        self._prev_min = self._cur_min = 0  # the two buckets' least arrival - stamp*tick
        self._bucket_at = 0
        self._last_raw = 0
        self._behind_since: int | None = None  # arrival of the first sample far behind
        # The window learnt: first and last (raw, arrival), samples, and per unit the
        # least arrival - raw * tick.
        self._first: tuple[int, int] | None = None
        self._last = (0, 0)
        self._count = 0
        self._mins = [0] * len(UNITS)

    def _start_learning(self) -> None:
        self.state = LEARNING
        self._first, self._count, self._behind_since = None, 0, None

    def next_notice(self) -> ClockNotice | None:
        """What was decided, oldest first; None when nothing is left."""
        return self._notices.popleft() if self._notices else None

    @property
    def offset_ns(self) -> int:
        """The offset mapped stamps get (0 unless ``mapped``)."""
        return min(self._prev_min, self._cur_min) if self.state == MAPPED else 0

    def stamp(self, raw: int, arrived_at: int) -> int:
        """The generation time of a sample stamped ``raw`` by its source that arrived at
        ``arrived_at`` (ns since the epoch, this host's clock), on this host's clock."""
        if self.state == FALLBACK:
            return arrived_at
        if self.state == LEARNING:
            return self._learn(raw, arrived_at)
        if self.state == NEAR:
            mapped = raw
        else:
            here = arrived_at - raw * self._tick
            if arrived_at - self._bucket_at >= BUCKET_S * NS_PER_S:
                self._prev_min, self._cur_min = self._cur_min, here
                self._bucket_at = arrived_at
            self._cur_min = min(self._cur_min, here)
            mapped = raw * self._tick + min(self._prev_min, self._cur_min)
        behind = arrived_at - mapped
        if behind > JUMP_S * NS_PER_S:
            if self._behind_since is None:
                self._behind_since = arrived_at
            if raw < self._last_raw or arrived_at - self._behind_since >= JUMP_S * NS_PER_S:
                self._relearn(raw, arrived_at, behind)
                return arrived_at
        else:
            self._behind_since = None
        self._last_raw = raw
        return mapped

    def _learn(self, raw: int, arrived_at: int) -> int:
        if self._first is None:
            self._first = (raw, arrived_at)
            self._mins = [arrived_at - raw * tick for _, _, tick in UNITS]
        else:
            self._mins = [min(m, arrived_at - raw * tick)
                          for m, (_, _, tick) in zip(self._mins, UNITS, strict=True)]
        self._last = (raw, arrived_at)
        self._count += 1
        self._last_raw = raw
        if self._count >= LEARN_SAMPLES and \
                arrived_at - self._first[1] >= LEARN_S * NS_PER_S:
            self._decide()
            if self.state != LEARNING:
                return self.stamp(raw, arrived_at)
        looks_near = abs(arrived_at - raw) <= NEAR_S * NS_PER_S
        return raw if looks_near else arrived_at

    def _decide(self) -> None:
        """Near, mapped or unusable, from the window learnt (``_learn``)."""
        assert self._first is not None
        (raw0, at0), (raw1, at1) = self._first, self._last
        span_s = (at1 - at0) / NS_PER_S
        ticks = raw1 - raw0
        window = f"{self._count} samples over {span_s:.1f} s"
        if ticks <= 0:
            how = "do not advance" if ticks == 0 else \
                f"go backwards ({ticks} ticks over {span_s:.1f} s of arrivals)"
            self._fall_back(f"source stamps {how}: stamped at arrival ({window})")
            return
        rates = [ticks * tick / (at1 - at0) for _, _, tick in UNITS]
        fits = [i for i, rate in enumerate(rates) if abs(rate - 1.0) <= RATE_TOLERANCE]
        if not fits:
            i = min(range(len(UNITS)), key=lambda k: abs(math.log(rates[k])))
            self._fall_back(
                f"source stamps do not advance like a clock: read as {UNITS[i][1]}, "
                f"{rates[i]:.3g} s pass for each second of this host's (none of "
                f"{', '.join(u for u, _, _ in UNITS)} is within {RATE_TOLERANCE:.0%} of "
                f"1): stamped at arrival ({window})")
            return
        i = fits[0]
        symbol, name, tick = UNITS[i]
        offset = self._mins[i]
        if tick == 1 and abs(offset) <= NEAR_S * NS_PER_S:
            self._decided(ClockNotice(
                NEAR, f"source stamps are this host's clock (ns since the epoch, least "
                f"arrival - stamp {offset / 1e6:.3f} ms over {window}): used as they are",
                symbol))
            self.state = NEAR
            return
        reading = raw1 * tick / NS_PER_S
        behind = (at1 - raw1 * tick) / NS_PER_S
        if reading < at1 / NS_PER_S / 2:
            origin = f"{name} since its boot or start ({symbol} since boot, {reading:.3g} s)"
        elif abs(behind) <= NEAR_S:
            origin = f"{name} since the epoch ({symbol}), on this host's clock"
        else:
            origin = (f"{name} since the epoch ({symbol}), {abs(behind):.3g} s "
                      f"{'behind' if behind > 0 else 'ahead of'} this host's clock")
        self._tick, self._unit = tick, symbol
        self._prev_min = self._cur_min = offset
        self._bucket_at = at1
        self.state = MAPPED
        self._decided(ClockNotice(
            MAPPED, f"source clock is {origin}: mapped onto this host's clock with offset "
            f"{offset / NS_PER_S:.6f} s (the least arrival - stamp over {window}, followed "
            f"over the last {BUCKET_S:.0f} to {2 * BUCKET_S:.0f} s)", symbol, offset))

    def _fall_back(self, text: str) -> None:
        self.state = FALLBACK
        self._decided(ClockNotice(FALLBACK, text))

    def _decided(self, notice: ClockNotice) -> None:
        """Told unless a clock learnt again turned out as it was before."""
        if self._before != (notice.kind, notice.unit):
            self._notices.append(notice)
        self._before = (notice.kind, notice.unit)

    def _relearn(self, raw: int, arrived_at: int, behind: int) -> None:
        was = self.state
        self._start_learning()
        self._notices.append(ClockNotice(
            RELEARN, f"source clock jumped back: a sample stamped {behind / NS_PER_S:.3g} s "
            f"before its arrival (it was {'mapped' if was == MAPPED else 'used as it is'}; "
            "a reboot?): learning it again, stamped at arrival meanwhile", self._unit))
        self._learn(raw, arrived_at)
