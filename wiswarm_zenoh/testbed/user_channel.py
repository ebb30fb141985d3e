"""The shared bottleneck without root: the tbf channel's shape (``ChannelSpec``) as a
relay on loopback with a ``SharedLink``, for anyone, on any machine with TCP.

The router listens on a loopback port only the leader side uses; the relay listens on
another and forwards each connection to the router, through the link. Followers are
clients of the router reached at the relay's port, so every byte they exchange with the
leader side crosses the link: their frames the shared uplink, polls and control its
downlink. Every session has shared memory off, as on the tbf channel: Zenoh would
otherwise hand frames of 3 kB and more between sessions of this host through shared
memory, past the relay. The relay runs in a process of its own (``run_link``), so the
leader's threads never hold its timing up.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from wiswarm_zenoh.programs import ReadySignal, StopSignal, wait_until_stopped
from wiswarm_zenoh.testbed.nodes import follower_spec, leader_spec, router_spec
from wiswarm_zenoh.testbed.relay import DelayRelay
from wiswarm_zenoh.testbed.shaper import SharedLink, describe
from wiswarm_zenoh.testbed.spec import ChannelSpec
from wiswarm_zenoh.transport import SessionSpec, free_tcp_port

LOCAL = "127.0.0.1"
SEND_BUFFER = "transport/link/tcp/so_sndbuf:262144"


@dataclass(frozen=True)
class UserChannel:
    """Where the router and the relay listen, and the link's shape."""

    spec: ChannelSpec
    router_port: int
    link_port: int

    @classmethod
    def on_free_ports(cls, spec: ChannelSpec) -> UserChannel:
        return cls(spec, free_tcp_port(), free_tcp_port())

    def router(self) -> SessionSpec:
        return router_spec(f"tcp/{LOCAL}:{self.router_port}")

    def leader(self) -> SessionSpec:
        return leader_spec(f"tcp/{LOCAL}:{self.router_port}")

    def follower(self) -> SessionSpec:
        spec = follower_spec(f"tcp/{LOCAL}:{self.link_port}")
        return dataclasses.replace(spec, cfg=(*spec.cfg, SEND_BUFFER))

    def describe(self) -> str:
        return (f"user-space shared link on {LOCAL}:{self.link_port} -> router :"
                f"{self.router_port}: {describe(self.spec)}")


def run_link(channel: UserChannel, stop: StopSignal, ready: ReadySignal | None = None) -> None:
    """The relay with the channel's link, until stopped (a ``Children`` target)."""
    relay = DelayRelay((LOCAL, channel.link_port), (LOCAL, channel.router_port), 0.0,
                       link=SharedLink(channel.spec))
    with relay:
        if ready is not None:
            ready.set()
        wait_until_stopped(stop)
