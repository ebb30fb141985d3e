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


def router_spec(*listen: str) -> SessionSpec:
    """The leader side's router, listening on ``listen``."""
    return SessionSpec(mode="router", listen=listen, cfg=(NO_SHARED_MEMORY,),
                       multicast_scouting=False)


def leader_spec(router: str) -> SessionSpec:
    """A peer of the router at ``router``, beside it on the leader side."""
    return SessionSpec(mode="peer", connect=(router,), listen=("tcp/127.0.0.1:0",),
                       cfg=(NO_SHARED_MEMORY,), multicast_scouting=False)


def follower_spec(router: str) -> SessionSpec:
    """A client of the router reached at ``router``, across the channel: every byte to
    the leader side crosses the shaped link (a client talks to its router only)."""
    return SessionSpec(mode="client", connect=(router,), cfg=(NO_SHARED_MEMORY,),
                       multicast_scouting=False)


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
        return router_spec(self.router_endpoint, f"tcp/127.0.0.1:{ROUTER_PORT}")

    def leader(self) -> SessionSpec:
        return leader_spec(f"tcp/127.0.0.1:{ROUTER_PORT}")

    def follower(self) -> SessionSpec:
        return follower_spec(self.router_endpoint)
