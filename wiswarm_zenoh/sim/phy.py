"""802.11n (2.4 GHz, 20 MHz, one spatial stream) timing and packet sizes.

Defaults describe a Raspberry Pi class 1x1 station in the paper's setting: HT-mixed
PPDUs at MCS 7 with the long guard interval (65 Mbit/s), no A-MPDU aggregation (each
IP packet is one MPDU), ACKs at the 24 Mbit/s legacy basic rate, short slots, and the
standard DCF contention window 15..1023 with at most 7 attempts per MPDU. The 6 us
signal extension of OFDM PPDUs in the 2.4 GHz band is included. Every IP packet of at
most 1500 B (the MTU) is one MAC frame, so a 50 kB UDP datagram is 34 MAC frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# Data bits per 4 us OFDM symbol, 20 MHz, one stream: HT MCS 0..7 and legacy OFDM rates.
HT_BITS_PER_SYMBOL = (26, 52, 78, 104, 156, 208, 234, 260)
LEGACY_BITS_PER_SYMBOL = {6: 24, 9: 36, 12: 48, 18: 72, 24: 96, 36: 144, 48: 192, 54: 216}

IP_HEADER = 20
UDP_HEADER = 8
TCP_HEADER = 32  # 20 B plus the 12 B timestamp option that Linux sends by default
MAC_QOS_HEADER = 26
LLC_SNAP = 8
FCS = 4
ACK_FRAME = 14
SERVICE_TAIL_BITS = 16 + 6


def udp_fragments(payload_bytes: int, mtu: int) -> list[int]:
    """IP packet sizes of one UDP datagram after IP fragmentation at ``mtu``: on any link."""
    per_fragment = (mtu - IP_HEADER) // 8 * 8
    remaining = payload_bytes + UDP_HEADER
    sizes = []
    while remaining > per_fragment:
        sizes.append(per_fragment + IP_HEADER)
        remaining -= per_fragment
    sizes.append(remaining + IP_HEADER)
    return sizes


@dataclass(frozen=True)
class WifiParams:
    """Physical and MAC parameters of the shared channel (seconds, bytes)."""

    mcs: int = 7
    basic_rate_mbps: int = 24
    broadcast_rate_mbps: int = 6
    slot: float = 9e-6
    sifs: float = 10e-6
    ht_preamble: float = 36e-6  # L-STF, L-LTF, L-SIG, HT-SIG, HT-STF, one HT-LTF
    legacy_preamble: float = 20e-6
    signal_extension: float = 6e-6
    cw_min: int = 15
    cw_max: int = 1023
    max_attempts: int = 7
    mtu: int = 1500
    # Packets a station may hold below the application: Linux's default socket send
    # buffer (net.core.wmem_default = 212992 B) holds about 128 full-size packets.
    mac_queue: int = 128

    def __post_init__(self) -> None:
        if not 0 <= self.mcs < len(HT_BITS_PER_SYMBOL):
            raise ValueError(f"mcs must be in 0..{len(HT_BITS_PER_SYMBOL) - 1}, got {self.mcs}")
        for name in ("basic_rate_mbps", "broadcast_rate_mbps"):
            if getattr(self, name) not in LEGACY_BITS_PER_SYMBOL:
                raise ValueError(f"{name} must be one of {sorted(LEGACY_BITS_PER_SYMBOL)}")
        if self.cw_min < 1 or self.cw_max < self.cw_min or self.max_attempts < 1:
            raise ValueError("need 1 <= cw_min <= cw_max and max_attempts >= 1")
        if self.mtu < 576 or self.mac_queue < 1:
            raise ValueError("mtu must be >= 576 and mac_queue >= 1")

    @property
    def difs(self) -> float:
        return self.sifs + 2 * self.slot

    @property
    def phy_rate_mbps(self) -> float:
        return HT_BITS_PER_SYMBOL[self.mcs] / 4.0


class Airtime:
    """Medium time of packets under ``WifiParams``, memoised per packet size."""

    def __init__(self, params: WifiParams) -> None:
        self.p = params
        self._cache: dict[tuple[str, int], float] = {}

    def _symbols(self, frame_bytes: int, bits_per_symbol: int) -> int:
        return math.ceil((SERVICE_TAIL_BITS + 8 * frame_bytes) / bits_per_symbol)

    def ack_time(self) -> float:
        bps = LEGACY_BITS_PER_SYMBOL[self.p.basic_rate_mbps]
        p = self.p
        return p.legacy_preamble + 4e-6 * self._symbols(ACK_FRAME, bps) + p.signal_extension

    def unicast_busy(self, ip_bytes: int) -> float:
        """Medium time of one unicast attempt: data PPDU, SIFS and the ACK (or its timeout)."""
        key = ("u", ip_bytes)
        busy = self._cache.get(key)
        if busy is None:
            mpdu = MAC_QOS_HEADER + LLC_SNAP + ip_bytes + FCS
            data = (
                self.p.ht_preamble
                + 4e-6 * self._symbols(mpdu, HT_BITS_PER_SYMBOL[self.p.mcs])
                + self.p.signal_extension
            )
            busy = self._cache[key] = data + self.p.sifs + self.ack_time()
        return busy

    def broadcast_busy(self, ip_bytes: int) -> float:
        """Medium time of one broadcast PPDU at the legacy broadcast rate (no ACK)."""
        key = ("b", ip_bytes)
        busy = self._cache.get(key)
        if busy is None:
            mpdu = MAC_QOS_HEADER + LLC_SNAP + ip_bytes + FCS
            bps = LEGACY_BITS_PER_SYMBOL[self.p.broadcast_rate_mbps]
            p = self.p
            busy = p.legacy_preamble + 4e-6 * self._symbols(mpdu, bps) + p.signal_extension
            self._cache[key] = busy
        return busy

    def udp_packets(self, payload_bytes: int) -> list[int]:
        """IP packet sizes of one UDP datagram after IP fragmentation at the MTU."""
        return udp_fragments(payload_bytes, self.p.mtu)

    @property
    def tcp_mss(self) -> int:
        return self.p.mtu - IP_HEADER - TCP_HEADER

    def frame_airtime(self, frame_bytes: int) -> float:
        """Mean medium time to carry one UDP frame from a lone station (no collisions)."""
        mean_backoff = self.p.cw_min / 2 * self.p.slot
        return sum(
            self.p.difs + mean_backoff + self.unicast_busy(size)
            for size in self.udp_packets(frame_bytes)
        )
