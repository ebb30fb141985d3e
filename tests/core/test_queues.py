"""Follower queues (FIFO with tail/head drop, LIFO with capacity k) and rate control."""

from __future__ import annotations

import random

import pytest

from wiswarm_zenoh.core.queues import RateController, Update, UpdateQueue


def _u(seq: int) -> Update:
    return Update(seq=seq, generated_at=float(seq), payload=bytes([seq]))


def _drain(queue: UpdateQueue) -> list[int]:
    out = []
    while (update := queue.pop()) is not None:
        out.append(update.seq)
    return out


def test_fifo_keeps_order_and_tail_drop_refuses_arrivals() -> None:
    queue = UpdateQueue("fifo", capacity=3, drop="tail")
    accepted = [queue.push(_u(i)) for i in range(1, 6)]
    assert accepted == [True, True, True, False, False]
    assert queue.dropped == 2
    assert queue.peek() is not None and queue.peek().seq == 1  # type: ignore[union-attr]
    assert _drain(queue) == [1, 2, 3]
    assert queue.pop() is None and queue.peek() is None


def test_fifo_head_drop_evicts_the_oldest() -> None:
    queue = UpdateQueue("fifo", capacity=3, drop="head")
    assert all(queue.push(_u(i)) for i in range(1, 6))
    assert queue.dropped == 2
    assert len(queue) == 3
    assert _drain(queue) == [3, 4, 5]


def test_lifo_capacity_one_keeps_only_the_freshest() -> None:
    queue = UpdateQueue("lifo", capacity=1)
    for i in range(1, 5):
        assert queue.push(_u(i))
    assert len(queue) == 1
    assert queue.dropped == 3
    assert _drain(queue) == [4]


def test_lifo_capacity_k_serves_newest_first_and_evicts_oldest() -> None:
    queue = UpdateQueue("lifo", capacity=3, drop="tail")  # LIFO ignores the drop rule
    for i in range(1, 6):
        assert queue.push(_u(i))
    assert queue.dropped == 2
    assert queue.peek() is not None and queue.peek().seq == 5  # type: ignore[union-attr]
    assert queue.pop() is not None
    assert queue.push(_u(6))
    assert _drain(queue) == [6, 4, 3]


def test_queue_rejects_capacity_below_one() -> None:
    with pytest.raises(ValueError, match="capacity"):
        UpdateQueue("lifo", capacity=0)


@pytest.mark.parametrize(("rate_hz", "times", "admitted"), [
    # first offer admitted and starts the grid 0, 0.125, 0.25, ... (binary-exact times)
    (8.0, [0.0, 0.0625, 0.12, 0.125, 0.2, 0.25], [True, False, False, True, False, True]),
    # late offers are admitted once; missed grid points are skipped, not made up in a burst
    (8.0, [0.0, 0.4375, 0.45, 0.49, 0.5], [True, True, False, False, True]),
    # the grid is anchored at the first offer, not at zero
    (4.0, [1.0625, 1.25, 1.3125, 1.5625], [True, False, True, True]),
])
def test_rate_control_grid(rate_hz: float, times: list[float], admitted: list[bool]) -> None:
    rc = RateController(rate_hz)
    assert [rc.admit(t) for t in times] == admitted


def test_rate_control_jittery_faster_producer_keeps_the_long_run_rate_exact() -> None:
    rng = random.Random(7)
    rc = RateController(10.0)
    t, admitted = 0.0, 0
    while t < 100.0:
        admitted += rc.admit(t)
        t += rng.uniform(0.005, 0.09)  # always faster than 10 Hz, heavily jittered
    # one admission per grid point 0, 0.1, ..., < 100 s: exactly 1000 (+-1 at the end)
    assert abs(admitted - 1000) <= 1


def test_rate_control_slower_producer_is_never_throttled() -> None:
    rc = RateController(10.0)
    assert all(rc.admit(0.15 * k) for k in range(200))


@pytest.mark.parametrize("rate", [0.0, -1.0, float("inf"), float("nan")])
def test_rate_control_rejects_bad_rates(rate: float) -> None:
    with pytest.raises(ValueError, match="rate_hz"):
        RateController(rate)
