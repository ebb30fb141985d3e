"""The sans-I/O core: every protocol decision, with time passed in as ``now``.

Nothing here reads a clock, opens a socket or starts a thread, so the same objects run
over Zenoh in real time and inside the simulator in virtual time.
"""

from wiswarm_zenoh.core import leader as _leader_module
from wiswarm_zenoh.core.aoi import AoITracker
from wiswarm_zenoh.core.config import FollowerConfig, LeaderConfig
from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.events import (
    Answering,
    Delivered,
    Event,
    Rejected,
    Silent,
    Stale,
    TimedOut,
)
from wiswarm_zenoh.core.follower import Follower
from wiswarm_zenoh.core.leader import FollowerStats, Leader, PollRequest, drain
from wiswarm_zenoh.core.policies import POLICIES, Policy, make_policy
from wiswarm_zenoh.core.wire import (
    MAX_WAYPOINTS,
    Control,
    Waypoint,
    encode_control,
    validate_waypoints,
)

COMPILED = not _leader_module.__file__.endswith(".py")
"""The core runs as mypyc-compiled extension modules (``make compiled``), not as Python."""

__all__ = [
    "COMPILED",
    "MAX_WAYPOINTS",
    "POLICIES",
    "Answering",
    "AoITracker",
    "Control",
    "Delivered",
    "Event",
    "Follower",
    "FollowerConfig",
    "FollowerStats",
    "Leader",
    "LeaderConfig",
    "Policy",
    "PollRequest",
    "Rejected",
    "Silent",
    "Stale",
    "TimedOut",
    "Waypoint",
    "WireError",
    "drain",
    "encode_control",
    "make_policy",
    "validate_waypoints",
]
