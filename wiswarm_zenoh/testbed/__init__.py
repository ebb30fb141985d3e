"""The emulated shared channel (Linux, root): network namespaces joined by a veth pair
shaped by ``tc tbf``, so real processes contend for one bottleneck like a swarm's air;
or the WiFi medium, ns-3's 802.11 with a station per follower; and the tbf channel's
shape without root (``UserChannel``: a relay on loopback with one token bucket and FIFO
per direction).
"""

from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.channel_records import (
    cleanup_leftovers,
    list_channels,
    remove_channel,
)
from wiswarm_zenoh.testbed.netns import enter, entered, run_in
from wiswarm_zenoh.testbed.nodes import Placement
from wiswarm_zenoh.testbed.spec import (
    ChannelSpec,
    LinkCounters,
    TestbedUnavailable,
    check_available,
    unavailable_reason,
)
from wiswarm_zenoh.testbed.user_channel import UserChannel, run_link
from wiswarm_zenoh.testbed.wifi import WifiMedium
from wiswarm_zenoh.testbed.wifi_spec import WifiSpec

__all__ = [
    "Channel",
    "ChannelSpec",
    "LinkCounters",
    "Placement",
    "TestbedUnavailable",
    "UserChannel",
    "WifiMedium",
    "WifiSpec",
    "check_available",
    "cleanup_leftovers",
    "enter",
    "entered",
    "list_channels",
    "remove_channel",
    "run_in",
    "run_link",
    "unavailable_reason",
]
