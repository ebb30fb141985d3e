"""The Zenoh shell: the core's leader and follower on real sessions (DESIGN.md section 3),
and what an application on them needs (process supervision, control, live tables)."""

from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.control import ControlListener
from wiswarm_zenoh.transport.demo import Children
from wiswarm_zenoh.transport.follower_node import FollowerNode
from wiswarm_zenoh.transport.freshest import Freshest
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.leader_node import LeaderNode
from wiswarm_zenoh.transport.report import LiveTable
from wiswarm_zenoh.transport.runners import (
    SUPERVISION_PERIOD,
    ReadySignal,
    StopSignal,
    run_router,
    wait_until_stopped,
)
from wiswarm_zenoh.transport.ticker import Ticker
from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port

__all__ = [
    "SUPERVISION_PERIOD",
    "BadInputLog",
    "Children",
    "ControlListener",
    "FollowerNode",
    "Freshest",
    "LeaderNode",
    "LiveTable",
    "ReadySignal",
    "SessionSpec",
    "StopSignal",
    "SwarmKeys",
    "Ticker",
    "free_tcp_port",
    "run_router",
    "wait_until_stopped",
]
