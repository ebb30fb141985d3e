"""The Zenoh shell: the core's leader and follower on real sessions (DESIGN.md section 3),
their keys, session flags and the subscriptions tools watch a swarm with. The programs
built on it (router, leader and follower processes, the demo) are ``programs``."""

from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.control import ControlListener
from wiswarm_zenoh.transport.follower_node import FollowerNode
from wiswarm_zenoh.transport.freshest import Freshest
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.leader_node import LeaderNode
from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port

__all__ = [
    "BadInputLog",
    "ControlListener",
    "FollowerNode",
    "Freshest",
    "LeaderNode",
    "SessionSpec",
    "SwarmKeys",
    "free_tcp_port",
]
