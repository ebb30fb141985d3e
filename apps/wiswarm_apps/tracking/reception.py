"""Where frames reach the leader, whatever carried them (polling or push): the AoI of
each UAV over the measurement window, a log of the deliveries, then the vision mailbox.

Both systems go through this one door, so their AoI is computed the same way (the
core's AoITracker, exact sawtooth areas) over the same window. The window opens when
the world's clock starts; before that the age counts from the window's start.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable
from dataclasses import dataclass

from wiswarm_apps.tracking.leader_app import Arrival, VisionLoop
from wiswarm_zenoh.core import AoITracker, Delivered


@dataclass(frozen=True)
class AoISummary:
    """One UAV's AoI at the leader over [start, now]."""

    age_s: float
    mean_aoi_s: float
    p95_aoi_s: float
    peak_aoi_s: float
    deliveries: int


@dataclass(frozen=True)
class DeliveryRow:
    """A delivery inside the window (leader clock), for the AoI histogram and CSV."""

    uav: str
    generated_at: float
    received_at: float


class Reception:
    """Thread-safe: the transport's thread delivers while the display reads."""

    def __init__(self, uavs: Iterable[str], vision: VisionLoop) -> None:
        self.uavs = sorted(uavs)
        self.vision = vision
        self._window: tuple[float, float] | None = None
        self._trackers: dict[str, AoITracker] = {}
        self._rows: list[DeliveryRow] = []
        self._lock = threading.Lock()

    def open_window(self, start: float, end: float) -> None:
        """Count AoI from `start` to `end` (leader clock); deliveries outside are not."""
        if not end > start:
            raise ValueError(f"window end {end} must be after its start {start}")
        with self._lock:
            self._window = (start, end)
            self._trackers = {uav: AoITracker(start) for uav in self.uavs}
            self._rows = []

    def on_delivered(self, event: Delivered) -> None:
        """The ``Leader``'s delivery handler."""
        self.receive(event.follower, event.payload, event.generated_at,
                     event.delivered_at)

    def receive(self, uav: str, payload: bytes, generated_at: float,
                received_at: float) -> None:
        with self._lock:
            window, tracker = self._window, self._trackers.get(uav)
            counted = window is not None and window[0] <= received_at <= window[1]
            if counted and tracker is not None and tracker.deliver(generated_at, received_at):
                self._rows.append(DeliveryRow(uav, generated_at, received_at))
        self.vision.submit(uav, Arrival(payload, generated_at, received_at, counted))

    def summary(self, now: float) -> dict[str, AoISummary]:
        """Per UAV, AoI up to `now` (clipped to the window); empty before it opens."""
        with self._lock:
            if self._window is None:
                return {}
            start, end = self._window
            t = min(max(now, start), end)
            return {
                uav: AoISummary(tracker.age(t), tracker.mean(t), tracker.percentile(0.95, t),
                                tracker.peak(t), tracker.deliveries)
                for uav, tracker in self._trackers.items()
            }

    def rows(self) -> list[DeliveryRow]:
        with self._lock:
            return list(self._rows)
