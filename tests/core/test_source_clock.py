"""A source's stamps on the follower's clock (``core.source_clock``): PX4's microseconds
since boot, a clock minutes off and a drifting one are mapped to within a millisecond or
two of the true generation time; this host's own clock is left as it is; simulated time,
a frozen counter and stamps going backwards fall back to arrival; a reboot is learnt
again. Each decision is told exactly once. Sources are simulated in integer ns: the
publish time ``t`` on the follower's clock, the stamp the source's clock gives at ``t``,
the arrival ``t`` + a latency (the way on the robot: a tenth of a millisecond and
more)."""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import pytest

from wiswarm_zenoh.core.source_clock import (
    FALLBACK,
    LEARNING,
    MAPPED,
    NEAR,
    RELEARN,
    ClockNotice,
    SourceClock,
)

S = 1_000_000_000
MS = 1_000_000
NOW = 1_764_000_000 * S  # the follower's clock at the start (ns since the epoch)
RATE_HZ = 50
MAPPED_WITHIN = 1 * MS  # what the least latency over a window leaves of the offset


@dataclass
class Stamped:
    true: int  # publish time, follower's clock
    raw: int
    arrived: int
    stamped: int
    state: str  # the clock's state after this sample


def publishes(seconds: float, seed: int = 1, start: int = NOW) -> Iterator[tuple[int, int]]:
    """(publish time, arrival) of a 50 Hz source whose loop wakes up to 2 ms off, over a
    way of 0.1 ms plus an exponential 0.3 ms, one sample in 50 held up 5 ms more."""
    rng = random.Random(seed)
    for k in range(round(seconds * RATE_HZ)):
        t = start + k * S // RATE_HZ + rng.randint(-2 * MS, 2 * MS)
        way = 100_000 + round(rng.expovariate(1 / 300_000)) + (5 * MS if k % 50 == 7 else 0)
        yield t, t + way


def run(clock: SourceClock, source: Callable[[int], int], seconds: float, seed: int = 1,
        start: int = NOW) -> list[Stamped]:
    out = []
    for t, arrived in publishes(seconds, seed, start):
        raw = source(t)
        out.append(Stamped(t, raw, arrived, clock.stamp(raw, arrived), clock.state))
    return out


def notices(clock: SourceClock) -> list[ClockNotice]:
    told = []
    while (notice := clock.next_notice()) is not None:
        told.append(notice)
    return told


def worst_error(samples: list[Stamped], state: str = MAPPED) -> int:
    return max(abs(s.stamped - s.true) for s in samples if s.state == state)


def test_px4_microseconds_since_boot_are_mapped_to_within_a_millisecond() -> None:
    """``hrt_absolute_time()``: 1234 s after the flight controller booted."""
    clock, boot = SourceClock(), NOW - 1234 * S
    samples = run(clock, lambda t: (t - boot) // 1000, 10.0)
    [told] = notices(clock)
    assert told.kind == MAPPED and told.unit == "µs"
    assert "microseconds since its boot" in told.text and "mapped onto" in told.text
    assert abs(told.offset_ns - boot) < MAPPED_WITHIN
    learning = [s for s in samples if s.state == LEARNING]
    decided = samples[len(learning)]
    assert decided.state == MAPPED
    assert 1 * S <= decided.arrived - samples[0].arrived <= 2 * S  # a second or so
    assert all(s.stamped == s.arrived for s in learning)  # never fresher than true
    assert worst_error(samples) < MAPPED_WITHIN
    assert all(s.stamped <= s.arrived for s in samples)


@pytest.mark.parametrize("off_s", [0.0, -0.4, 0.6])
def test_this_hosts_clock_is_used_as_it_is(off_s: float) -> None:
    """rmw_zenoh's own stamps (ns since the epoch), on this host's clock or a clock
    within a second of it: untouched, from the first sample on."""
    clock = SourceClock()
    samples = run(clock, lambda t: t + round(off_s * S), 5.0)
    assert all(s.stamped == s.raw for s in samples)
    [told] = notices(clock)
    assert told.kind == NEAR and "used as they are" in told.text
    assert samples[-1].state == NEAR


@pytest.mark.parametrize("off_s", [-300.0, 300.0])
def test_an_epoch_clock_minutes_off_is_mapped(off_s: float) -> None:
    clock = SourceClock()
    samples = run(clock, lambda t: t + round(off_s * S), 5.0)
    [told] = notices(clock)
    assert told.kind == MAPPED and told.unit == "ns"
    assert f"300 s {'ahead of' if off_s > 0 else 'behind'} this host's clock" in told.text
    assert worst_error(samples) < MAPPED_WITHIN


def test_milliseconds_since_start_are_mapped() -> None:
    clock = SourceClock()
    samples = run(clock, lambda t: (t - NOW + 42 * S) // MS, 5.0)
    [told] = notices(clock)
    assert (told.kind, told.unit) == (MAPPED, "ms")
    assert worst_error(samples) < 2 * MS  # a whole tick is 1 ms


@pytest.mark.parametrize(("name", "source", "why"), [
    ("simulated time at 2x", lambda t: 2 * (t - NOW) + 7 * S,
     "do not advance like a clock: read as nanoseconds, 2 s pass"),
    ("a frozen counter", lambda t: 123_456, "do not advance"),
    ("a counter going backwards", lambda t: 10**15 - (t - NOW) // 1000, "go backwards"),
    ("a clock at a tenth of the speed", lambda t: (t - NOW) // 10, "0.1 s pass"),
])
def test_stamps_that_are_no_clock_fall_back_to_arrival(
        name: str, source: Callable[[int], int], why: str) -> None:
    clock = SourceClock()
    samples = run(clock, source, 5.0)
    [told] = notices(clock)
    assert told.kind == FALLBACK and why in told.text and "stamped at arrival" in told.text
    assert all(s.stamped == s.arrived for s in samples), name
    assert samples[-1].state == FALLBACK


def test_a_reboot_is_learnt_again_and_told_once() -> None:
    """PX4 reboots after 30 s: its stamps start again from a few seconds."""
    clock, boot = SourceClock(), NOW - 1234 * S
    reboot_at = NOW + 30 * S
    before = run(clock, lambda t: (t - boot) // 1000, 30.0)
    boot2 = reboot_at + 2 * S  # the first sample comes 3 s after the new boot
    after = run(clock, lambda t: (t - boot2) // 1000, 30.0, start=reboot_at + 5 * S)
    kinds = [n.kind for n in notices(clock)]
    assert kinds == [MAPPED, RELEARN]  # mapped again as before: not told twice
    assert after[0].state == LEARNING and after[0].stamped == after[0].arrived
    relearning = [s for s in after if s.state == LEARNING]
    assert all(s.stamped == s.arrived for s in relearning)
    assert relearning[-1].arrived - relearning[0].arrived < 2 * S
    assert worst_error(before) < MAPPED_WITHIN and worst_error(after) < MAPPED_WITHIN
    assert abs(clock.offset_ns - boot2) < MAPPED_WITHIN


def test_a_clock_learnt_again_that_changed_is_told() -> None:
    """A node on this host's clock that switches to simulated time: told it jumped, then
    that its stamps are no clock."""
    clock = SourceClock()
    run(clock, lambda t: t, 3.0)
    run(clock, lambda t: 2 * (t - NOW), 5.0, start=NOW + 3 * S)
    assert [n.kind for n in notices(clock)] == [NEAR, RELEARN, FALLBACK]


def test_samples_held_up_by_a_stalled_follower_are_no_jump() -> None:
    """The follower stalls 2 s: the samples queued meanwhile arrive together, their stamps
    still advancing. They keep their own (true) times; nothing is learnt again."""
    clock, boot = SourceClock(), NOW - 1234 * S
    run(clock, lambda t: (t - boot) // 1000, 5.0)
    stall_end = NOW + 7 * S
    held = []
    for k in range(100):  # published from 5 s to 7 s, all arriving at 7 s
        t = NOW + 5 * S + k * S // RATE_HZ
        raw = (t - boot) // 1000
        held.append((t, clock.stamp(raw, stall_end + k * 1000)))
    after = run(clock, lambda t: (t - boot) // 1000, 5.0, start=stall_end + 20 * MS)
    assert [n.kind for n in notices(clock)] == [MAPPED]
    assert max(abs(stamped - t) for t, stamped in held) < MAPPED_WITHIN
    assert worst_error(after) < MAPPED_WITHIN


@pytest.mark.parametrize("ppm", [100, -100])
def test_a_drift_of_100_ppm_is_followed_for_an_hour(ppm: int) -> None:
    """A crystal 100 ppm off drifts 360 ms in an hour; the sliding window keeps the
    mapped time within a few ms of the truth throughout (a slow clock lags by the
    window's length times the drift: 20 s x 100 ppm = 2 ms)."""
    clock, boot = SourceClock(), NOW - 600 * S
    samples = run(clock, lambda t: (t - boot) * (1_000_000 + ppm) // 1_000_000_000, 3600.0)
    [told] = notices(clock)
    assert told.kind == MAPPED
    assert worst_error(samples) < 2 * MS + MAPPED_WITHIN
    last = samples[-1]
    fixed = last.raw * 1000 + told.offset_ns  # the offset learnt first, never followed
    assert abs(fixed - last.true) > 300 * MS  # what following the drift saved
