"""The dashboard's Zenoh side: subscribers only (it never slows the leader: the leader's
delivery stream is sent while a subscriber matches, and a put does not wait for it).

Every payload is checked (``records``); a bad one is counted and logged with its key
expression, and skipped. Samples arrive on Zenoh's threads and change the state there.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import zenoh

from wiswarm_zenoh.dashboard.records import (
    parse_deliveries,
    parse_leader,
    parse_points,
    parse_stats,
    parse_tracking,
)
from wiswarm_zenoh.dashboard.state import SwarmState
from wiswarm_zenoh.transport.keys import ROOT, SwarmKeys
from wiswarm_zenoh.transport.watch import Watch, json_payload

log = logging.getLogger(__name__)

EXPERIMENTS = f"{ROOT}/experiments"
TRACKING_LEAF = "tracking"  # wiswarm_apps.tracking.uav_app's key: wiswarm/<swarm>/<uav>/tracking


def points_key(run: str) -> str:
    """Where an experiment run's points go (``live_points``)."""
    return f"{EXPERIMENTS}/{run}/points"


class Feed:
    """Subscribes to a swarm's delivery stream, stats and tracking JSON, and to every
    experiment run's points, into ``state`` until ``close()``."""

    def __init__(self, session: zenoh.Session, state: SwarmState) -> None:
        self.keys = SwarmKeys(state.swarm)
        self._state = state
        handlers: dict[str, Callable[[str, Any], None]] = {
            self.keys.leader_deliveries: self._on_deliveries,
            self.keys.all_stats: self._on_stats,
            f"{self.keys.prefix}/*/{TRACKING_LEAF}": self._on_tracking,
            points_key("*"): self._on_points,
        }
        self._watch = Watch(session, {key: json_payload(handler)
                                      for key, handler in handlers.items()}, state.bad_input)

    def _on_deliveries(self, key: str, data: Any) -> None:
        deliveries, bad = parse_deliveries(data)
        refused = self._state.add_deliveries(deliveries)
        if refused:
            bad.append(f"{refused} records of followers past the dashboard's limit")
        for reason in bad:
            self._state.bad_input.report(key, reason)

    def _on_stats(self, key: str, data: Any) -> None:
        if key == self.keys.leader_stats:
            self._state.set_leader(parse_leader(data))
            return
        follower = self.keys.follower_of(key, "stats")
        if follower is None:
            raise ValueError("not a follower's stats key")
        if not self._state.set_stats(parse_stats(data, follower)):
            raise ValueError("a follower past the dashboard's limit")

    def _on_tracking(self, key: str, data: Any) -> None:
        uav = self.keys.follower_of(key, TRACKING_LEAF)
        if uav is None:
            raise ValueError("not a UAV's tracking key")
        if not self._state.set_tracking(parse_tracking(data, uav)):
            raise ValueError("a UAV past the dashboard's limit")

    def _on_points(self, key: str, data: Any) -> None:
        self._state.set_run(parse_points(data, key.split("/")[2]))

    def close(self) -> None:
        self._watch.close()
