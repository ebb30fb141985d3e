"""The freshest value per key for a slower consumer: a newer value replaces one not yet
taken, none is ever queued or lost when it is the newest, keys are served in turn."""

from __future__ import annotations

import threading

from wiswarm_zenoh.transport import Freshest

PUTS = 5000


def test_a_newer_value_replaces_one_not_taken_and_keeps_its_turn() -> None:
    slots: Freshest[str, int] = Freshest()
    assert slots.put("a", 1) is None
    assert slots.put("b", 1) is None
    assert slots.put("a", 2) == 1  # replaced unsent: given back to be counted
    assert slots.take() == ("a", 2)  # "a" began to wait first
    assert slots.put("a", 3) is None  # taken: nothing to replace
    assert slots.take() == ("b", 1)
    assert slots.take() == ("a", 3)


def test_close_wakes_a_waiting_consumer_and_drops_what_waits() -> None:
    slots: Freshest[str, int] = Freshest()
    taken: list[tuple[str, int] | None] = []
    consumer = threading.Thread(target=lambda: taken.append(slots.take()))
    consumer.start()
    slots.close()
    consumer.join(10.0)
    assert not consumer.is_alive() and taken == [None]
    slots.put("a", 1)
    assert slots.take() is None


def test_a_burst_from_another_thread_ends_with_the_freshest_of_every_key() -> None:
    slots: Freshest[str, int] = Freshest()
    keys = ("a", "b", "c")
    replaced = [0]

    def produce() -> None:
        for i in range(PUTS):
            for key in keys:
                replaced[0] += slots.put(key, i) is not None

    producer = threading.Thread(target=produce)
    producer.start()
    seen: dict[str, list[int]] = {key: [] for key in keys}
    while any(not values or values[-1] != PUTS - 1 for values in seen.values()):
        item = slots.take()
        assert item is not None
        seen[item[0]].append(item[1])
    producer.join()
    for values in seen.values():
        assert values == sorted(set(values))  # never an older one after a newer
    assert sum(map(len, seen.values())) + replaced[0] == PUTS * len(keys)
