"""The leader's door to other ecosystems (the ROS 2 bridge, ``wiswarm_zenoh.ros2``):
what a bridge is handed, on the poll thread, and what it may do back. Defined here so
that the leader needs none of them to run."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import zenoh

from wiswarm_zenoh.core import Delivered, FollowerStats


class ControlTarget(Protocol):
    """What a bridge may do to the leader: set a follower's control (checked as for any
    caller: ValueError for waypoints the wire does not allow), and say a follower is
    there by another sign than its member token (its token is then asked for faster)."""

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None: ...

    def expect(self, follower: str) -> None: ...


class LeaderBridge(Protocol):
    """Takes each delivery and each whole round of stats, on the poll thread (keep it
    short), until ``close()``."""

    def deliver(self, event: Delivered) -> None: ...

    def stats(self, records: Sequence[FollowerStats], now: float) -> None: ...

    def close(self) -> None: ...


class BridgeOptions(Protocol):
    """How to open a bridge for the leader of ``swarm`` on ``session``."""

    def open(self, session: zenoh.Session, swarm: str, control: ControlTarget) -> LeaderBridge:
        ...
