"""``wiswarm/<swarm>/leader/deliveries``: every delivery and every unanswered poll, for
tools that draw the exact AoI sawtooth (the dashboard) rather than sampled stats.

Batched: records gather on the poll thread and go out as one JSON list ten times a
second, so a subscriber costs a put per 100 ms, not one per poll. Nothing is gathered
while no subscriber matches (the publisher's matching status, as for ``fresh``).
"""

from __future__ import annotations

import json
import math
from typing import cast

import zenoh

from wiswarm_zenoh.core import Delivered, TimedOut
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

BATCH_PERIOD = 0.1  # seconds: 10 Hz, as DESIGN.md's contract says


class DeliveryStream:
    """Gathers ``Delivered`` and ``TimedOut`` events and publishes them in batches."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys,
                 period: float = BATCH_PERIOD) -> None:
        self._period = period
        self._batch: list[dict[str, object]] = []
        self._publisher = session.declare_publisher(
            keys.leader_deliveries, encoding=zenoh.Encoding.APPLICATION_JSON)
        # Set on Zenoh's thread (a flag, nothing more); current from the start.
        self.listening = cast(zenoh.MatchingStatus, self._publisher.matching_status).matching
        self._listener = self._publisher.declare_matching_listener(
            zenoh.handlers.Callback(self._on_matching, indirect=False))
        self.due = math.inf  # when the batch gathered goes out (inf: nothing gathered)

    def _on_matching(self, status: zenoh.MatchingStatus) -> None:
        self.listening = status.matching

    def add(self, event: Delivered | TimedOut, now: float) -> None:
        """Keep one record for the next batch (nothing while nobody listens). ``now``
        stands for the moment a timed-out poll was given up."""
        if not self.listening:
            return
        if isinstance(event, Delivered):
            record: dict[str, object] = {
                "follower": event.follower, "outcome": "delivered",
                "generated_at": event.generated_at, "delivered_at": event.delivered_at}
        else:
            record = {"follower": event.follower, "outcome": "timeout",
                      "generated_at": None, "delivered_at": now}
        if not self._batch:
            self.due = now + self._period
        self._batch.append(record)

    def flush(self) -> None:
        """Publish what was gathered, as one JSON list."""
        if self._batch:
            self._publisher.put(json.dumps(self._batch, separators=(",", ":")))
            self._batch = []
        self.due = math.inf

    def close(self) -> None:
        self.flush()
        undeclare(self._listener, self._publisher)
