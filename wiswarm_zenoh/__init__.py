"""wiswarm-zenoh: Age-of-Information polling middleware (WiSwarm) on Eclipse Zenoh.

Open a ``zenoh.Session`` and put a ``Follower`` on each robot (``offer`` its bytes, or
give it what the robot already publishes, a ``ZenohSource`` or
``wiswarm_zenoh.ros2.Ros2TopicSource``; get its waypoints in ``on_control``) and a
``Leader`` where the data is used (deliveries to a callable, a ``FifoChannel`` or a
``RingChannel``; ``set_control`` steers a follower).
An ``Observer`` watches any swarm's stats and deliveries, for tools.
"""

__version__ = "0.1.0"

from wiswarm_zenoh.api.follower import Follower
from wiswarm_zenoh.api.handlers import Channel, FifoChannel, Handler, RingChannel
from wiswarm_zenoh.api.leader import Leader
from wiswarm_zenoh.api.observer import DeliveryRecord, Observation, Observer
from wiswarm_zenoh.core import Delivered, FollowerConfig, FollowerStats, LeaderConfig, Waypoint
from wiswarm_zenoh.transport.source_feed import ZenohSource
from wiswarm_zenoh.transport.telemetry import LeaderSummary

__all__ = [
    "Channel",
    "Delivered",
    "DeliveryRecord",
    "FifoChannel",
    "Follower",
    "FollowerConfig",
    "FollowerStats",
    "Handler",
    "Leader",
    "LeaderConfig",
    "LeaderSummary",
    "Observation",
    "Observer",
    "RingChannel",
    "Waypoint",
    "ZenohSource",
    "__version__",
]
