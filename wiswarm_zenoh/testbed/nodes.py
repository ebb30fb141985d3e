"""Who runs where on the emulated channel, with which Zenoh sessions.

The leader side (router, and the polling leader or a baseline's receiver) lives in the
channel's leader namespace; the followers in the follower namespace, clients of that
router across the shaped veth. Every session has shared memory off: Zenoh moves
payloads of 3 kB and more between sessions of one host through shared memory by
default, and the frames would then never cross the shaped link at all.
"""

from __future__ import annotations

from dataclasses import dataclass

from wiswarm_zenoh.transport.zenoh_config import SessionSpec

NO_SHARED_MEMORY = "transport/shared_memory/enabled:false"
ROUTER_PORT = 7447
SOCKET_PORT = 7450  # the UDP and TCP baselines' receiver


@dataclass(frozen=True)
class Placement:
    """The two sides of one channel: namespaces and the leader side's address."""

    leader_ns: str
    follower_ns: str
    leader_addr: str

    @property
    def router_endpoint(self) -> str:
        return f"tcp/{self.leader_addr}:{ROUTER_PORT}"

    @property
    def socket_receiver(self) -> str:
        """Where UDP and TCP baselines send their frames (``HOST:PORT``)."""
        return f"{self.leader_addr}:{SOCKET_PORT}"

    def router(self) -> SessionSpec:
        """Listens on the veth (followers) and on loopback (the leader beside it)."""
        return SessionSpec(mode="router", listen=(self.router_endpoint,
                                                  f"tcp/127.0.0.1:{ROUTER_PORT}"),
                           cfg=(NO_SHARED_MEMORY,), multicast_scouting=False)

    def leader(self) -> SessionSpec:
        """A peer of the router on the leader side's loopback."""
        return SessionSpec(mode="peer", connect=(f"tcp/127.0.0.1:{ROUTER_PORT}",),
                           listen=("tcp/127.0.0.1:0",), cfg=(NO_SHARED_MEMORY,),
                           multicast_scouting=False)

    def follower(self) -> SessionSpec:
        """A client of the router across the channel: every byte to the leader side
        crosses the shaped link (a client talks to its router only)."""
        return SessionSpec(mode="client", connect=(self.router_endpoint,),
                           cfg=(NO_SHARED_MEMORY,), multicast_scouting=False)
