"""Every delivery a leader or a baseline's receiver makes, as a CSV file: the exact
AoI sawtooth, for plots and the testbed's figures."""

from __future__ import annotations

import csv

from wiswarm_zenoh.core import Delivered
from wiswarm_zenoh.programs.frames import capture_time


class DeliveryRecord:
    """Every delivery as a CSV row (follower, update_seq, generated_at, delivered_at,
    bytes; leader clock): the exact AoI sawtooth, for plots.

    With ``capture_stamps`` the generation time is the one synthetic frames carry
    (``capture_time``) instead of the leader's estimate: ground truth where every node
    shares one clock (the testbed), so polling and push are measured alike."""

    FIELDS = ("follower", "update_seq", "generated_at", "delivered_at", "bytes")

    def __init__(self, path: str, capture_stamps: bool = False) -> None:
        # Line-buffered: a leader killed mid-run (a fault the testbed injects) keeps its rows.
        self._file = open(path, "w", newline="", buffering=1)  # noqa: SIM115 - see close()
        self._writer = csv.writer(self._file)
        self._writer.writerow(self.FIELDS)
        self._capture_stamps = capture_stamps

    def __call__(self, event: Delivered) -> None:
        generated_at = capture_time(event.payload) if self._capture_stamps else \
            event.generated_at
        self.row(event.follower, event.update_seq, generated_at, event.delivered_at,
                 len(event.payload))

    def row(self, follower: str, update_seq: int, generated_at: float, delivered_at: float,
            size: int) -> None:
        """One delivery from plain values (a receiver that is not the polling leader)."""
        self._writer.writerow((follower, update_seq, f"{generated_at:.6f}",
                               f"{delivered_at:.6f}", size))

    def close(self) -> None:
        self._file.close()
