"""The emulated shared channel (Linux, root): network namespaces joined by a veth pair
shaped by ``tc tbf``, so real processes contend for one bottleneck like a swarm's air.
"""

from wiswarm_zenoh.testbed.channel import (
    Channel,
    cleanup_leftovers,
    list_channels,
    remove_channel,
)
from wiswarm_zenoh.testbed.netns import enter, run_in
from wiswarm_zenoh.testbed.spec import (
    ChannelSpec,
    LinkCounters,
    TestbedUnavailable,
    check_available,
    unavailable_reason,
)

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
