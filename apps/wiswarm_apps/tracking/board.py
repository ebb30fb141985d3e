"""The demo's live table: per UAV, AoI at the leader, tracking error, car in view.

AoI and vision counts are the leader's own; tracking error and the car-in-view share
come from each UAV's JSON on ``wiswarm/<swarm>/<uav>/tracking`` (only the UAV knows
where it is at every instant). The transport's LiveTable draws the lines.
"""

from __future__ import annotations

import json
import logging
import math
import threading
from collections.abc import Mapping, Sequence
from contextlib import ExitStack
from typing import Any

import zenoh

from wiswarm_apps.tracking.leader_app import VisionStats
from wiswarm_apps.tracking.reception import AoISummary
from wiswarm_apps.tracking.uav_app import TRACKING_LEAF
from wiswarm_zenoh.transport import BadInputLog, SwarmKeys

log = logging.getLogger(__name__)

HEADER = (f"{'uav':>6} {'AoI ms':>7} {'mean':>7} {'p95':>7} {'deliv/s':>8} {'vision/s':>8}"
          f" {'err m':>6} {'mean m':>6} {'in view':>7} {'weight':>6}")


class TrackingBoard:
    """The latest tracking record of every UAV (a subscriber on their tracking keys)."""

    def __init__(self, session: zenoh.Session, swarm: str) -> None:
        self.keys = SwarmKeys(swarm)
        self._latest: dict[str, dict[str, Any]] = {}
        self._lock = threading.Lock()
        self.bad_input = BadInputLog(log)
        self._entities = ExitStack()
        self._entities.enter_context(session.declare_subscriber(
            f"{self.keys.prefix}/*/{TRACKING_LEAF}", self._on_sample
        ))

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        uav = self.keys.follower_of(key, TRACKING_LEAF)
        try:
            record = json.loads(sample.payload.to_bytes())
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            self.bad_input.report(key, f"not JSON: {exc}")
            return
        if uav is None or not isinstance(record, dict):
            self.bad_input.report(key, "not a tracking record")
            return
        with self._lock:
            self._latest[uav] = record

    def latest(self) -> dict[str, dict[str, Any]]:
        with self._lock:
            return dict(self._latest)

    def close(self) -> None:
        self._entities.close()


def _number(value: object, scale: float = 1.0, digits: int = 1, width: int = 7) -> str:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return f"{'-':>{width}}"
    return f"{value * scale:>{width}.{digits}f}"


def table_lines(uavs: Sequence[str], elapsed_s: float, aoi: Mapping[str, AoISummary],
                vision: Mapping[str, VisionStats], tracking: Mapping[str, Mapping[str, Any]],
                weights: Mapping[str, float]) -> list[str]:
    """Header and one row per UAV; rates are over the `elapsed_s` measured so far."""
    span = max(elapsed_s, 1e-9)
    lines = [HEADER]
    for uav in uavs:
        a, v, t = aoi.get(uav), vision.get(uav), tracking.get(uav, {})
        lines.append(" ".join((
            f"{uav:>6}",
            _number(a and a.age_s, 1e3), _number(a and a.mean_aoi_s, 1e3),
            _number(a and a.p95_aoi_s, 1e3),
            _number(a and a.deliveries / span, width=8, digits=0),
            _number(v and v.processed / span, width=8, digits=0),
            _number(t.get("error_m"), digits=2, width=6),
            _number(t.get("mean_error_m"), digits=2, width=6),
            _number(t.get("in_view_share"), 100.0, 0, 6) + "%",
            _number(weights.get(uav), digits=2, width=6),
        )))
    return lines
