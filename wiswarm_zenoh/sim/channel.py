"""What the senders (WiSwarm, the UDP and TCP baselines) ask of a channel model, so that
the same senders run over the 802.11 medium and over the testbed's shaped link."""

from __future__ import annotations

from typing import Protocol

from wiswarm_zenoh.sim.medium import Mpdu, Station


class Channel(Protocol):
    """Takes a station's packets; each one's handler hears ``(data, ok, now)`` when it
    leaves the channel. False: the station's queue (its socket) has no room."""

    def send(self, station: Station, mpdu: Mpdu) -> bool: ...


class PacketCosts(Protocol):
    """The IP packets that carry a message, and each packet's cost on the channel (the
    ``busy`` of its Mpdu): seconds of airtime on 802.11, bytes on the wire on the link."""

    def unicast_busy(self, ip_bytes: int) -> float: ...

    def broadcast_busy(self, ip_bytes: int) -> float: ...

    def udp_packets(self, payload_bytes: int) -> list[int]: ...

    @property
    def tcp_mss(self) -> int: ...
