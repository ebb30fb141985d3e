"""The joins and deliveries ``bench_scale.py``'s leader reports, kept cheaply on its poll
thread, and what they come to over a measuring window: deliveries and mean AoI per
follower."""

from __future__ import annotations

import threading
from array import array
from collections import defaultdict

from wiswarm_zenoh.core import Delivered
from wiswarm_zenoh.core.aoi import AoITracker


class Watch:
    """The leader's joins and deliveries. Its callbacks run on the poll thread: a few
    appends to arrays, nothing more, and no object per delivery for the leader's garbage
    collector to walk (tens of thousands of tuples would lengthen its pauses)."""

    def __init__(self, followers: list[str]) -> None:
        self.index = {follower: i for i, follower in enumerate(followers)}
        self.joined = 0
        self.all_joined = threading.Event()
        self.delivered: set[str] = set()
        self.all_delivered = threading.Event()
        self.who, self.generated, self.at = array("l"), array("d"), array("d")

    def on_join(self, follower: str) -> None:
        self.joined += 1
        if self.joined == len(self.index):
            self.all_joined.set()

    def on_delivery(self, event: Delivered) -> None:
        self.who.append(self.index[event.follower])
        self.generated.append(event.generated_at)
        self.at.append(event.delivered_at)
        if not self.all_delivered.is_set():
            self.delivered.add(event.follower)
            if len(self.delivered) == len(self.index):
                self.all_delivered.set()


def window_figures(watch: Watch, followers: list[str], start: float,
                   end: float) -> tuple[dict[str, int], dict[str, float]]:
    """Deliveries of each follower in [start, end], and its time-average AoI there (from
    the age it had at ``start``)."""
    last_before: dict[int, float] = {}
    inside: dict[int, list[tuple[float, float]]] = defaultdict(list)
    for i, generated, delivered in zip(watch.who, watch.generated, watch.at, strict=True):
        if delivered < start:
            last_before[i] = max(generated, last_before.get(i, generated))
        elif delivered <= end:
            inside[i].append((generated, delivered))
    counts, means = {}, {}
    for follower in followers:
        i = watch.index[follower]
        tracker = AoITracker(start, max(0.0, start - last_before.get(i, start)))
        for generated, delivered in inside[i]:
            tracker.deliver(generated, delivered)
        counts[follower], means[follower] = len(inside[i]), tracker.mean(end)
    return counts, means
