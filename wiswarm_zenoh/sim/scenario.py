"""One run over the ``wifi`` channel: WiSwarm or a push baseline, N followers, one seed.

``newest`` is the adaptive baseline: each follower keeps only its camera's newest frame
(WiSwarm's camera, ``sample_rate``) and writes it to TCP through a small send buffer the
moment its previous write completed, so it has no rate to tune.

``Workload``, ``start_system`` and ``result_of`` are what a run is on any channel model
(the ``link`` model shares them): the system, its followers' cameras, and its metrics.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import partial

from wiswarm_zenoh.core.aoi import AoITracker
from wiswarm_zenoh.core.config import FollowerConfig, LeaderConfig
from wiswarm_zenoh.sim.channel import Channel, PacketCosts
from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.medium import Medium, Station
from wiswarm_zenoh.sim.metrics import FollowerMetrics, WifiResult
from wiswarm_zenoh.sim.phy import Airtime, WifiParams
from wiswarm_zenoh.sim.slotted import check_range
from wiswarm_zenoh.sim.source import PeriodicFifo, PeriodicNewest
from wiswarm_zenoh.sim.tcp import TcpFlow
from wiswarm_zenoh.sim.udp import UdpPush
from wiswarm_zenoh.sim.wiswarm import STAMP, WiswarmNetwork

SYSTEMS = ("wiswarm", "udp", "tcp", "newest")
TCP_SYSTEMS = ("tcp", "newest")
RATELESS_SYSTEMS = ("wiswarm", "newest")  # their cameras' sample_rate: no push rate
# newest: bytes of SO_SNDBUF asked for (``wiswarm follower --newest-only``'s default);
# the kernel doubles it, and its bookkeeping overhead is left out.
NEWEST_SEND_BUFFER = 16384
PAPER_FRAME_BYTES = 224 * 224  # the paper's grayscale frames, 49 kB
# Per-attempt MAC frame success on each follower's link, drawn per follower: rate
# adaptation (e.g. minstrel) settles near 10 % frame loss, here with some spread.
DEFAULT_RELIABILITY = (0.85, 0.95)
# A sequential poll over Zenoh through a router took 0.5-0.8 ms on loopback
# (DESIGN.md section 3): the hosts' share of every poll cycle.
DEFAULT_HOST_DELAY = 0.5e-3


@dataclass(frozen=True)
class Workload:
    """What runs over a channel, whatever the channel: the system, its N followers and
    their cameras; validated on construction (ValueError names the field)."""

    n: int
    system: str = "wiswarm"
    rate: float = 50.0  # udp and tcp: frames per second into the FIFO
    frame_bytes: int = PAPER_FRAME_BYTES
    duration: float = 240.0
    seed: int = 0
    fifo_frames: int | None = None  # the baselines' application FIFO (None: unbounded)
    sample_rate: float = 100.0  # WiSwarm's and newest's cameras
    send_buffer: int = NEWEST_SEND_BUFFER  # newest: bytes of SO_SNDBUF
    host_delay: float = DEFAULT_HOST_DELAY
    policy: str = "whittle"
    follower_config: FollowerConfig = field(default_factory=FollowerConfig)
    # WiSwarm's leader: the index per unit of expected poll time (False: the paper's),
    # its longest poll timeout, and whether each follower's is learnt below it.
    price_by_time: bool = True
    timeout: float = 0.3
    adaptive_timeout: bool = True
    # seconds between repeats of unchanged control (LeaderConfig); 0: with every poll
    control_period: float = LeaderConfig.control_period

    def __post_init__(self) -> None:
        if self.n < 1:
            raise ValueError(f"n must be >= 1, got {self.n}")
        if self.system not in SYSTEMS:
            raise ValueError(f"system must be one of {', '.join(SYSTEMS)}, got {self.system!r}")
        for name in ("rate", "duration", "sample_rate"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value}")
        if not (math.isfinite(self.host_delay) and self.host_delay >= 0):
            raise ValueError(f"host_delay must be >= 0, got {self.host_delay}")
        limit = self.follower_config.max_update_bytes
        if not STAMP.size <= self.frame_bytes <= limit:
            raise ValueError(
                f"frame_bytes must be in {STAMP.size}..{limit} (max_update_bytes), "
                f"got {self.frame_bytes}"
            )
        if self.fifo_frames is not None and self.fifo_frames < 1:
            raise ValueError(f"fifo_frames must be >= 1, got {self.fifo_frames}")
        if self.fifo_frames is not None and self.system == "newest":
            raise ValueError("fifo_frames: newest keeps one frame, the newest")
        if self.send_buffer < 1:
            raise ValueError(f"send_buffer must be >= 1 byte, got {self.send_buffer}")
        self.leader_config()

    def leader_config(self) -> LeaderConfig:
        return LeaderConfig(policy=self.policy, price_by_time=self.price_by_time,
                            timeout=self.timeout, adaptive_timeout=self.adaptive_timeout,
                            control_period=self.control_period)


DIES_AT = 1.0  # seconds: when a dead follower's link stops delivering, under WiSwarm


@dataclass(frozen=True)
class WifiScenario(Workload):
    """A run over the 802.11 medium: the workload, each link's reliability, the PHY."""

    reliability: tuple[float, float] = DEFAULT_RELIABILITY
    params: WifiParams = field(default_factory=WifiParams)
    # followers (the first ones) whose link delivers nothing: p = 0; under WiSwarm from
    # DIES_AT on, once they answered (one that never answered is silent from its first
    # miss and costs one poll, whatever the index: a dead follower is one that died)
    dead: int = 0

    def __post_init__(self) -> None:
        super().__post_init__()
        check_range("reliability", *self.reliability, 0.0, 1.0)
        if not 0 <= self.dead < self.n:
            raise ValueError(f"dead must be in [0, n), got {self.dead}")


def start_system(
    s: Workload, engine: Engine, channel: Channel, costs: PacketCosts, leader: Station,
    stations: Sequence[Station], p: Sequence[float], rng: random.Random,
    udp: type[UdpPush] = UdpPush,
) -> tuple[list[AoITracker], WiswarmNetwork | None]:
    """Start ``s.system`` over the channel (``udp``: the UDP sender's model): the
    leader's AoI tracker of every follower, and the WiSwarm network (None for a push
    baseline, whose cameras' phases ``rng`` draws)."""
    sinks = [AoITracker(0.0) for _ in range(s.n)]
    if s.system == "wiswarm":
        net = WiswarmNetwork(
            engine, channel, costs, leader, stations, p, sinks, s.frame_bytes, s.sample_rate,
            s.host_delay, s.leader_config(), s.follower_config,
        )
        net.start()
        return sinks, net
    newest = s.system == "newest"
    for i, station in enumerate(stations):
        fifo = (PeriodicNewest(s.sample_rate, rng.random() / s.sample_rate) if newest
                else PeriodicFifo(s.rate, rng.random() / s.rate, s.fifo_frames))
        if s.system == "udp":
            udp(engine, channel, station, fifo, costs, s.frame_bytes, p[i], sinks[i]).start()
        else:
            TcpFlow(
                engine, channel, station, leader, fifo, costs, s.frame_bytes, p[i], sinks[i],
                2 * s.send_buffer if newest else None,
            ).start()
    return sinks, None


def result_of(
    s: Workload, sinks: Sequence[AoITracker], net: WiswarmNetwork | None,
    channel: dict[str, float],
) -> WifiResult:
    """The run's metrics at ``s.duration``: the channel's counters, and WiSwarm's polls
    and timeouts."""
    followers = [
        FollowerMetrics.from_tracker(f"uav{i}", sink, s.duration, s.frame_bytes)
        for i, sink in enumerate(sinks)
    ]
    if net is not None:
        channel["polls"] = float(net.leader.polls)
        channel["timeouts"] = float(sum(net.leader.stats(f, s.duration).timeouts
                                        for f in net.leader.followers))
    return WifiResult(
        system=s.system, n=s.n, rate=None if s.system in RATELESS_SYSTEMS else s.rate,
        frame_bytes=s.frame_bytes, duration=s.duration, seed=s.seed, followers=followers,
        channel=channel,
    )


def run_wifi(s: WifiScenario) -> WifiResult:
    """Simulate ``s.duration`` seconds and measure every follower's AoI on ground truth."""
    rng = random.Random(s.seed)
    p = [rng.uniform(*s.reliability) for _ in range(s.n)]
    if s.system != "wiswarm":
        p[:s.dead] = [0.0] * s.dead
    engine = Engine(rng.getrandbits(64))
    medium = Medium(engine, s.params)
    leader = medium.station("leader")
    stations = [medium.station(f"uav{i}") for i in range(s.n)]
    sinks, net = start_system(s, engine, medium, Airtime(s.params), leader, stations, p, rng)
    if net is not None:
        for i in range(s.dead):
            engine.at(DIES_AT, partial(net.cut, i))
    engine.run(s.duration)
    return result_of(s, sinks, net, {
        "utilisation": medium.busy_time / s.duration,
        "transmissions": float(medium.transmissions),
        "collision_share": medium.collisions / max(medium.transmissions, 1),
    })
