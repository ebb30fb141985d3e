"""The Zenoh shell: the core's leader and follower on real sessions (DESIGN.md section 3)."""

from wiswarm_zenoh.transport.follower_node import FollowerNode
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.leader_node import LeaderNode
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

__all__ = ["FollowerNode", "LeaderNode", "SessionSpec", "SwarmKeys"]
