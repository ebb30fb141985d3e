"""The camera's FIFO: periodic frames, lazy admission equal to an eager tail-drop FIFO."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.sim.source import PeriodicFifo


def test_unbounded_fifo_hands_out_every_frame_in_generation_order() -> None:
    fifo = PeriodicFifo(rate=10.0, phase=0.05, capacity=None)
    assert fifo.pull(0.0) is None
    assert fifo.next_frame_time(0.0) == pytest.approx(0.05)
    got = [fifo.pull(1.0) for _ in range(10)]
    assert got == pytest.approx([0.05 + k / 10 for k in range(10)])
    assert fifo.pull(1.0) is None
    assert fifo.next_frame_time(1.0) == pytest.approx(1.05)
    assert fifo.dropped == 0


def test_full_fifo_drops_arrivals_at_the_tail_like_an_eager_queue() -> None:
    fifo = PeriodicFifo(rate=1.0, phase=0.0, capacity=3)
    assert fifo.pull(0.0) == 0.0  # frame 0 taken at once; frames 1..9 arrive by t = 9
    assert fifo.pull(9.0) == 1.0  # an eager FIFO kept 1, 2, 3 and dropped 4..9
    assert len(fifo) == 2
    assert fifo.dropped == 6
    assert [fifo.pull(10.5), fifo.pull(10.5), fifo.pull(10.5)] == [2.0, 3.0, 10.0]
    assert fifo.pull(10.5) is None


def test_frame_times_are_exact_at_their_own_instants() -> None:
    fifo = PeriodicFifo(rate=3.0, phase=0.1, capacity=None)
    t = 0.1 + 7 / 3.0
    assert fifo.generated(t) == 8  # frame 7 is generated exactly at t, despite rounding


@pytest.mark.parametrize("rate", [0.0, -1.0, float("inf")])
def test_impossible_rates_are_refused(rate: float) -> None:
    with pytest.raises(ValueError, match="rate"):
        PeriodicFifo(rate=rate, phase=0.0, capacity=None)
