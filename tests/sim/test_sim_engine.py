"""The event engine: time order, insertion order on ties, no going back in time."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.sim.engine import Engine


def test_events_fire_in_time_order_and_ties_in_insertion_order() -> None:
    engine = Engine(seed=1)
    fired: list[tuple[float, str]] = []
    for time, name in [(2.0, "c"), (1.0, "a"), (2.0, "d"), (1.0, "b"), (0.5, "first")]:
        engine.at(time, lambda t=time, n=name: fired.append((t, n)))
    engine.run(until=10.0)
    assert fired == [(0.5, "first"), (1.0, "a"), (1.0, "b"), (2.0, "c"), (2.0, "d")]
    assert engine.now == 10.0


def test_now_is_the_time_of_the_firing_event_and_later_events_wait() -> None:
    engine = Engine(seed=1)
    seen: list[float] = []

    def chain() -> None:
        seen.append(engine.now)
        engine.after(1.5, chain)

    engine.at(0.25, chain)
    engine.run(until=4.0)
    assert seen == [0.25, 1.75, 3.25]
    assert engine.peek() == 4.75
    engine.run(until=5.0)
    assert seen[-1] == 4.75


def test_scheduling_in_the_past_is_refused() -> None:
    engine = Engine(seed=1)
    engine.run(until=1.0)
    with pytest.raises(ValueError, match="past"):
        engine.at(0.5, lambda: None)


def test_the_same_seed_gives_the_same_random_stream() -> None:
    a, b, c = Engine(seed=7), Engine(seed=7), Engine(seed=8)
    draws = [a.rng.random() for _ in range(5)]
    assert draws == [b.rng.random() for _ in range(5)]
    assert draws != [c.rng.random() for _ in range(5)]
