"""The emulated shared channel (Linux, root): network namespaces joined by a veth pair
shaped by ``tc tbf``, so real processes contend for one bottleneck like a swarm's air.
"""

from wiswarm_zenoh.testbed.channel import (
    Channel,
    ChannelSpec,
    LinkCounters,
    TestbedUnavailable,
    check_available,
    cleanup_leftovers,
    list_channels,
    remove_channel,
    unavailable_reason,
)
from wiswarm_zenoh.testbed.netns import enter, run_in

__all__ = [
    "Channel",
    "ChannelSpec",
    "LinkCounters",
    "TestbedUnavailable",
    "check_available",
    "cleanup_leftovers",
    "enter",
    "list_channels",
    "remove_channel",
    "run_in",
    "unavailable_reason",
]
