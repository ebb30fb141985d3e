"""The ``link`` channel: exactly the testbed's shaped link, one ``tc tbf`` per direction.

The testbed puts the leader side (router and leader) and the followers in two network
namespaces joined by one veth pair, and shapes each direction's egress with ``tc tbf
rate R burst B latency Q``. Each direction here is that qdisc: a bucket of B bytes of
tokens filling at R in front of a FIFO of at most ``R Q + B`` bytes (tc's own limit).
A packet leaves when the bucket holds its length, at once if it finds the FIFO empty
and the tokens there (the kernel dequeues right after each enqueue); one that would
take the backlog past the limit is tail-dropped. The leader's station feeds the
downlink, every follower's the one uplink they share. Choices, stated:

- A packet counts what tbf counts, the skb's length: the IP packet and its 14 B
  Ethernet header; no FCS, preamble or gap (a veth has none, tbf counts none).
- The bucket is modelled, not neglected: a full 32 kB bucket lets 21 full-size packets
  out at once, and during a WiSwarm cycle it refills while the uplink idles (the poll's
  way down, the turnaround), so a cycle takes the reply's bytes at R, not that plus the
  idle time (0.5 ms of 21 ms at 20 Mbit/s).
- ``send`` is the kernel's enqueue: False is a tail drop (NET_XMIT_DROP, no handler
  call); a station's ``room()`` is its sender's own check of its socket. UDP
  (``SocketUdpPush``): a blocking socket of wmem_default 212992 B takes a whole datagram
  while it has under 92 MTU-size skbs (2304 B truesize) in the qdisc, and a blocked
  writer wakes below half that; IP sends the fragments in order and none after a
  dropped one, so a frame arrives only if all its fragments got in. TCP: TCP Small
  Queues lets a flow keep two skbs (two segments each at these rates) and send one
  more, 6 packets, so N < 59 flows never fill the qdisc and TCP's backlog waits in the
  application, as in the kernel (where a local drop would be no loss anyway).
- WiSwarm's polls and replies ride Zenoh's TCP link: a message is MSS-sized segments
  (``ZenohAirtime``); Zenoh's framing bytes and the TCP ACKs on the downlink are left
  out (a few bytes per reply; the ACKs pass on the downlink's tokens).
- No propagation delay (a veth), no random loss: the only loss is a tail drop.
"""

from __future__ import annotations

import math
import random
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from wiswarm_zenoh.core.config import FollowerConfig, LeaderConfig
from wiswarm_zenoh.core.follower import Follower
from wiswarm_zenoh.core.leader import Leader, drain
from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.medium import Mpdu, Station
from wiswarm_zenoh.sim.metrics import WifiResult
from wiswarm_zenoh.sim.phy import IP_HEADER, TCP_HEADER, udp_fragments
from wiswarm_zenoh.sim.scenario import (
    RATELESS_SYSTEMS,
    TCP_SYSTEMS,
    Workload,
    result_of,
    start_system,
)
from wiswarm_zenoh.sim.udp import UdpPush
from wiswarm_zenoh.token_bucket import TokenBucket
from wiswarm_zenoh.units import MAX_RATE_BPS, MIN_RATE_BPS, format_rate

ETHERNET_HEADER = 14
UDP_SOCKET_PACKETS = 212_992 // 2304  # net.core.wmem_default / truesize of a 1500 B skb
TCP_SMALL_QUEUE_PACKETS = 6  # TSQ: 2 x truesize of a 2-segment skb queued, one more sent
MTU_RANGE = (576, 9000)


@dataclass(frozen=True)
class LinkParams:
    """The shaped link, as ``tc tbf`` is given it: rates (bit/s; the downlink's defaults
    to the uplink's), the queue's latency (s), the bucket (bytes) and the MTU."""

    rate_bps: int = 20_000_000
    down_rate_bps: int | None = None
    queue_s: float = 0.2
    burst_bytes: int = 32 * 1024
    mtu: int = 1500

    def __post_init__(self) -> None:
        for name in ("rate_bps", "down_rate_bps"):
            value = getattr(self, name)
            if value is not None and not MIN_RATE_BPS <= value <= MAX_RATE_BPS:
                raise ValueError(f"{name} must be between {format_rate(MIN_RATE_BPS)} and "
                                 f"{format_rate(MAX_RATE_BPS)}, got {value}")
        if not (math.isfinite(self.queue_s) and self.queue_s > 0):
            raise ValueError(f"queue_s must be a finite number > 0, got {self.queue_s}")
        if not MTU_RANGE[0] <= self.mtu <= MTU_RANGE[1]:
            raise ValueError(f"mtu must be in {MTU_RANGE[0]}..{MTU_RANGE[1]}, got {self.mtu}")
        if self.burst_bytes < self.mtu + ETHERNET_HEADER:
            raise ValueError(f"burst_bytes must hold a full-size frame ({self.mtu} + "
                             f"{ETHERNET_HEADER} B), got {self.burst_bytes}")

    @property
    def down_bps(self) -> int:
        return self.rate_bps if self.down_rate_bps is None else self.down_rate_bps

    def limit_bytes(self, rate_bps: int) -> int:
        """tc's queue limit for a direction of that rate: ``rate * latency + burst``."""
        return int(rate_bps / 8 * self.queue_s + self.burst_bytes)


class LinkAirtime:
    """Packets as Ethernet/IPv4 cuts them (UDP 8 B, TCP 32 B with timestamps, fragments
    of 1480 B at MTU 1500), each costing its length as tbf counts it (``Mpdu.busy``)."""

    def __init__(self, link: LinkParams) -> None:
        self.mtu = link.mtu

    def unicast_busy(self, ip_bytes: int) -> float:
        return float(ip_bytes + ETHERNET_HEADER)

    def broadcast_busy(self, ip_bytes: int) -> float:
        """On Ethernet a broadcast costs what a unicast does."""
        return self.unicast_busy(ip_bytes)

    def udp_packets(self, payload_bytes: int) -> list[int]:
        return udp_fragments(payload_bytes, self.mtu)

    @property
    def tcp_mss(self) -> int:
        return self.mtu - IP_HEADER - TCP_HEADER


class ZenohAirtime(LinkAirtime):
    """WiSwarm's messages as Zenoh's TCP link carries them: the packets of a message
    (``udp_packets``, all WiSwarm's network asks for) are MSS-sized TCP segments."""

    def udp_packets(self, payload_bytes: int) -> list[int]:
        mss = self.tcp_mss
        full, rest = divmod(payload_bytes, mss)
        sizes = [mss + IP_HEADER + TCP_HEADER] * full
        if rest or not sizes:
            sizes.append(rest + IP_HEADER + TCP_HEADER)
        return sizes


class Shaper:
    """One direction's ``tbf``: a token bucket in front of a byte-limited FIFO."""

    __slots__ = ("_area", "_bucket", "_engine", "_queue", "_sent_at_once", "_since", "backlog",
                 "bytes_per_s", "drops", "limit", "packets", "sent_bytes")

    def __init__(self, engine: Engine, rate_bps: int, limit: int, burst: int,
                 sent_at_once: list[Mpdu]) -> None:
        self._engine = engine
        self.bytes_per_s = rate_bps / 8
        self.limit = limit
        self._sent_at_once = sent_at_once  # their handlers run after ``send`` returns
        self._queue: deque[tuple[Station, Mpdu]] = deque()
        self._bucket = TokenBucket(self.bytes_per_s, burst)  # tbf starts with a full bucket
        self.backlog = 0.0  # bytes queued (tbf's backlog; a leaving packet is not)
        self._area = 0.0  # integral of the backlog over time
        self._since = 0.0
        self.sent_bytes = 0.0
        self.packets = 0
        self.drops = 0

    @property
    def busy_time(self) -> float:
        """Seconds of the rate the carried bytes used."""
        return self.sent_bytes / self.bytes_per_s

    def mean_backlog(self, now: float) -> float:
        return (self._area + self.backlog * (now - self._since)) / now if now > 0 else 0.0

    def _add_backlog(self, now: float, delta: float) -> None:
        self._area += self.backlog * (now - self._since)
        self._since = now
        self.backlog += delta

    def offer(self, station: Station, mpdu: Mpdu) -> bool:
        """Send at once (an empty FIFO and the tokens there), enqueue, or tail-drop (False)."""
        now = self._engine.now
        size = mpdu.busy
        if not self._queue and self._bucket.wait_s(size, now) == 0.0:
            self._bucket.take(size, now)
            self.sent_bytes += size
            self.packets += 1
            self._sent_at_once.append(mpdu)
            return True
        if self.backlog + size > self.limit:
            self.drops += 1
            return False
        self._queue.append((station, mpdu))
        station.queue.append(mpdu)
        self._add_backlog(now, size)
        if len(self._queue) == 1:
            self._wait_for_tokens(now)
        return True

    def _wait_for_tokens(self, now: float) -> None:
        self._engine.at(now + self._bucket.wait_s(self._queue[0][1].busy, now), self._leave)

    def _leave(self) -> None:
        """The head has its tokens: it goes; the next head starts waiting for its own."""
        now = self._engine.now
        station, mpdu = self._queue.popleft()
        station.queue.popleft()
        size = mpdu.busy
        self._bucket.take(size, now)
        self._add_backlog(now, -size)
        self.sent_bytes += size
        self.packets += 1
        if self._queue:
            self._wait_for_tokens(now)
        mpdu.handler(mpdu.data, True, now)


class LinkMedium:
    """The veth pair: the leader side's station sends into the downlink, the followers'
    stations into the uplink; ``send`` has the 802.11 medium's interface. UDP over it is
    ``SocketUdpPush``: ``UdpPush`` expects a MAC queue that drops nothing it admitted."""

    def __init__(self, engine: Engine, link: LinkParams) -> None:
        self.engine = engine
        self._sent_at_once: list[Mpdu] = []
        self.uplink = Shaper(engine, link.rate_bps, link.limit_bytes(link.rate_bps),
                             link.burst_bytes, self._sent_at_once)
        self.downlink = Shaper(engine, link.down_bps, link.limit_bytes(link.down_bps),
                               link.burst_bytes, self._sent_at_once)
        self.stations: list[Station] = []
        self._shaper_of: list[Shaper] = []

    def station(self, name: str, limit: int | None = None, downlink: bool = False) -> Station:
        """Add a sender whose socket keeps at most ``limit`` packets in the qdisc (default:
        a UDP socket's buffer); ``downlink``: the leader side's."""
        limit = UDP_SOCKET_PACKETS if limit is None else limit
        if limit < 1:
            raise ValueError(f"limit must be >= 1, got {limit}")
        st = Station(name, len(self.stations), limit, 0)
        self.stations.append(st)
        self._shaper_of.append(self.downlink if downlink else self.uplink)
        return st

    def send(self, st: Station, mpdu: Mpdu) -> bool:
        """Enqueue a packet into the station's direction; False: tail-dropped. The handler
        of a packet that leaves at once runs after ``send`` returns, never inside it."""
        pending = bool(self._sent_at_once)
        if not self._shaper_of[st.index].offer(st, mpdu):
            return False
        if self._sent_at_once and not pending:
            self.engine.at(self.engine.now, self._flush)
        return True

    def _flush(self) -> None:
        sent = self._sent_at_once[:]
        self._sent_at_once.clear()  # the shapers keep appending to this very list
        now = self.engine.now
        for mpdu in sent:
            mpdu.handler(mpdu.data, True, now)

    @property
    def busy_time(self) -> float:
        return self.uplink.busy_time + self.downlink.busy_time

    @property
    def transmissions(self) -> int:
        return self.uplink.packets + self.downlink.packets

    def counters(self) -> dict[str, float]:
        """Each direction's carried rate, utilisation (the first burst can lift it just
        past 1), tail drops and mean backlog so far, named as the testbed measures them."""
        now = self.engine.now
        out: dict[str, float] = {}
        for name, shaper in (("uplink", self.uplink), ("downlink", self.downlink)):
            out[f"{name}_mbps"] = shaper.sent_bytes * 8 / now / 1e6
            out[f"{name}_utilisation"] = shaper.busy_time / now
            out[f"{name}_drops"] = float(shaper.drops)
            out[f"{name}_backlog_kb"] = shaper.mean_backlog(now) / 1e3
        out["transmissions"] = float(self.transmissions)
        return out


class SocketUdpPush(UdpPush):
    """The UDP baseline as the kernel sends it into a qdisc: a blocking socket takes a
    whole datagram while under its buffer (a blocked writer wakes below half of it), and
    IP sends its fragments in order until one is dropped, then none of the rest."""

    _held: float | None = None  # the frame a blocked ``sendto`` holds
    _blocked = False

    def _pump(self) -> None:
        now = self._engine.now
        station = self._station
        last = len(self._busy) - 1
        while True:
            if self._held is None:
                self._held = self._fifo.pull(now)
                if self._held is None:
                    self._wake_at_next_frame(now)
                    return
            queued = len(station.queue)
            if queued >= station.limit or (self._blocked and 2 * queued >= station.limit):
                self._blocked = True
                return
            self._blocked = False
            self._frame += 1
            for i, busy in enumerate(self._busy):
                data = (self._frame, i == last, self._held)
                if not self._medium.send(station, Mpdu(busy, self._p, True, self._done, data)):
                    break
            self._held = None


@dataclass(frozen=True)
class LinkScenario(Workload):
    """A run over the shaped link: the workload and the link; no random loss."""

    link: LinkParams = field(default_factory=LinkParams)


def run_link(s: LinkScenario) -> WifiResult:
    """Simulate ``s.duration`` seconds over the link; AoI on ground truth, as ``run_wifi``."""
    rng = random.Random(s.seed)
    engine = Engine(rng.getrandbits(64))
    medium = LinkMedium(engine, s.link)
    leader = medium.station("leader", downlink=True)
    limit = TCP_SMALL_QUEUE_PACKETS if s.system in TCP_SYSTEMS else None
    stations = [medium.station(f"uav{i}", limit) for i in range(s.n)]
    costs = ZenohAirtime(s.link) if s.system == "wiswarm" else LinkAirtime(s.link)
    sinks, net = start_system(s, engine, medium, costs, leader, stations, [1.0] * s.n, rng,
                              SocketUdpPush)
    engine.run(s.duration)
    return result_of(s, sinks, net, medium.counters())


def link_curve(ns: Sequence[int], systems: Sequence[tuple[str, float | None]],
               link: LinkParams, frame_bytes: int, duration: float, seed: int
               ) -> list[WifiResult]:
    """The model's run for every N and every (system, push rate; None for WiSwarm and
    newest), N outermost: the curve a testbed report draws beside what it measured."""
    results = []
    for n in ns:
        for system, rate in systems:
            if (rate is None) != (system in RATELESS_SYSTEMS):
                wanted = "a push rate" if rate is None else "no push rate (None)"
                raise ValueError(f"rate: {system} takes {wanted}, got {rate}")
            s = LinkScenario(n=n, system=system, frame_bytes=frame_bytes, duration=duration,
                             seed=seed, link=link)
            results.append(run_link(s if rate is None else replace(s, rate=rate)))
    return results


def _exchange(frame_bytes: int, control_period: float) -> tuple[int, int, int]:
    """Bytes of a steady poll's control message (none unless ``control_period`` is 0:
    unchanged control goes out once a period, not with each poll), the poll
    (acknowledging the reply before), and the reply that carries one whole frame, as
    the core encodes them."""
    leader = Leader(LeaderConfig(control_period=control_period), random.Random(0))
    follower = Follower("uav0", FollowerConfig())
    leader.add_follower("uav0", 0.0)
    sizes = (0, 0, 0)
    for now in (0.0, 0.001):  # the first poll acknowledges nothing yet
        follower.offer(bytes(frame_bytes), now)
        request = leader.next_poll(now)
        assert request is not None, "a lone idle follower is always polled"
        reply = follower.on_poll(request.payload, now, now)
        if len(reply) < frame_bytes:
            raise ValueError(f"frame_bytes must fit one reply (the fragment size), "
                             f"got {frame_bytes}")
        leader.receive_reply("uav0", reply, now)
        drain(leader)
        sizes = (len(request.control or b""), len(request.payload), len(reply))
    return sizes


def poll_cycle(frame_bytes: int, link: LinkParams, host_delay: float,
               control_period: float = LeaderConfig.control_period) -> tuple[float, float]:
    """(S, reply): the steady round-robin poll cycle, and the part of it from the
    follower's answer to the delivery. S is the slowest of the reply's bytes at the
    uplink's rate, the poll's at the downlink's, and the chain poll, turnaround, reply
    when each starts with a full bucket: tokens hide the idle time a bucket can hold."""
    air = ZenohAirtime(link)
    control, poll, reply = _exchange(frame_bytes, control_period)
    down = sum(air.unicast_busy(ip) for size in (control, poll) for ip in air.udp_packets(size))
    up = sum(air.unicast_busy(ip) for ip in air.udp_packets(reply))
    up_s, down_s = up * 8 / link.rate_bps, down * 8 / link.down_bps
    up_full = max(up - link.burst_bytes, 0.0) * 8 / link.rate_bps  # with a full bucket
    down_full = max(down - link.burst_bytes, 0.0) * 8 / link.down_bps
    cycle = max(up_s, down_s, down_full + host_delay + up_full)
    if down_s > up_s:  # the poll sets the pace; the uplink's bucket refills meanwhile
        return cycle, up_full
    # The reply sets the pace (or the chain does): it has what tokens the poll and the
    # turnaround left it.
    return cycle, max(up_full, up_s - down_full - host_delay)


def round_robin_floor(n: int, frame_bytes: int, link: LinkParams, host_delay: float,
                      sample_rate: float | None = None,
                      control_period: float = LeaderConfig.control_period) -> float:
    """WiSwarm's mean AoI (s) polling N equal followers in turn over a lossless link:
    S (N/2 + 1) less the part of each cycle before the follower answers (it samples
    then), plus half the camera's period if it samples at ``sample_rate`` (None: a
    fresh update every poll)."""
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    s, reply = poll_cycle(frame_bytes, link, host_delay, control_period)
    camera = 0.0 if sample_rate is None else 0.5 / sample_rate
    return s * n / 2 + reply + camera
