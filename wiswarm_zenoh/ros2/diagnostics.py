"""The leader's view of each follower as ``diagnostic_msgs/msg/DiagnosticArray``: the
message every ROS 2 monitoring tool (rqt_runtime_monitor, Foxglove's panels) reads."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from wiswarm_zenoh.core import FollowerStats
from wiswarm_zenoh.ros2.messages import header, message_class

VALUES = ("aoi_s", "mean_aoi_s", "p95_aoi_s", "p_hat", "weight", "polls", "deliveries",
          "timeouts", "errors")


def diagnostic_array(swarm: str, records: Sequence[FollowerStats], now: float) -> Any:
    """One status per follower, named ``wiswarm/<swarm>/<follower>``: OK while it is a
    member, STALE once its token went; its stats as key-value pairs; its hardware the
    robot it is a stream of (a robot's streams are one hardware in monitoring tools)."""
    status, pair = (message_class(f"diagnostic_msgs/msg/{name}")
                    for name in ("DiagnosticStatus", "KeyValue"))
    statuses = [status(
        level=status.OK if record.present else status.STALE,
        name=f"wiswarm/{swarm}/{record.follower}",
        message=(f"AoI {record.aoi_s * 1e3:.1f} ms, p {record.p_hat:.2f}" if record.present
                 else "left the swarm"),
        hardware_id=record.robot,
        values=[pair(key=name, value=f"{getattr(record, name):g}") for name in VALUES])
        for record in records]
    return message_class("diagnostic_msgs/msg/DiagnosticArray")(header=header(now),
                                                                status=statuses)
