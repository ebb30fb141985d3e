"""The edge-cloud experiment: the same sites, followers and WAN, polled three ways.

- ``direct``: one cloud leader polls every follower through both routers, one poll in
  flight (a swarm has one leader today): every poll pays the WAN's round trip and the
  site's channel.
- ``hierarchy xK``: each site's edge leader polls its followers over the channel (one
  at a time, as the paper), and the cloud leader polls the (site, follower) pairs from
  the edges with K polls in flight (``wiswarm leader --in-flight K``): the WAN is no
  shared radio channel, and K = 1 leaves it idle while each poll crosses it and back.
- ``edge alone``: the edge leaders without a cloud: the local floor.

Each setup gets swarms of its own names and fresh processes; routers and relays stay up
for the whole experiment. With ``secure`` every node runs closed (``edge_cloud_secure``)
and the cloud polls the edges only (no ``direct``: its rules have no such path). AoI is
measured as in ``run``: from the capture time every synthetic frame carries (one host
clock), over a window after a warm-up, which starts once every follower was delivered
where it is measured (the cloud, or the edge).
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import multiprocessing
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from wiswarm_zenoh.core.config import InFlight
from wiswarm_zenoh.experiments.edge_cloud_nodes import LeadersOptions, run_leaders, run_relays
from wiswarm_zenoh.experiments.edge_cloud_secure import CLOUD, Specs
from wiswarm_zenoh.experiments.edge_cloud_topology import MAX_SITES, EdgeCloud, Site, WanSpec
from wiswarm_zenoh.experiments.testbed_study import FRAME_OVERHEAD
from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.frames import FRAME_BYTES, FRAME_HEADER_BYTES
from wiswarm_zenoh.programs.runners import FollowerOptions, run_followers, run_router
from wiswarm_zenoh.sim.metrics import FollowerMetrics
from wiswarm_zenoh.testbed.netns import run_in
from wiswarm_zenoh.testbed.run import ending, read_record, window_metrics
from wiswarm_zenoh.testbed.spec import ChannelSpec

log = logging.getLogger(__name__)

SAMPLE_RATE = 100.0  # cameras, fps (the paper's WiSwarm)
READY_TIMEOUT = 60.0  # s for a setup's leaders to deliver every follower once
SUPERVISE_PERIOD = 0.5
MAX_FOLLOWERS = 100  # per site
FOLLOWERS, EDGES, CLOUD_LAYER = range(3)  # layers of a setup's processes, started in this order


@dataclass(frozen=True)
class Setup:
    """One way of polling: ``direct``, ``hierarchy`` (the cloud leader keeping ``k``
    polls in flight) or ``edge`` (no cloud)."""

    kind: str
    k: InFlight = 1

    @property
    def label(self) -> str:
        return {"direct": "direct", "edge": "edge alone"}.get(
            self.kind, "hierarchy, K auto" if self.k == "auto" else f"hierarchy x{self.k}")

    @property
    def tag(self) -> str:
        return {"direct": "d", "edge": "e"}.get(self.kind, f"h{self.k}")

    @property
    def in_flight(self) -> InFlight:
        """Polls in flight on the WAN (``auto``: as the cloud leader finds)."""
        return 0 if self.kind == "edge" else self.k


@dataclass(frozen=True)
class EdgeCloudConfig:
    """What to run; validated on construction (ValueError names the field)."""

    sites: int = 2
    followers: int = 6
    local: ChannelSpec = field(default_factory=ChannelSpec)
    wan: WanSpec = field(default_factory=WanSpec)
    in_flight: tuple[InFlight, ...] | None = None  # None: 1, wan_in_flight(), pairs, auto
    duration: float = 15.0
    warmup: float = 5.0
    frame_bytes: int = FRAME_BYTES
    secure: bool = False  # every node with its certificate, every router its rules

    def __post_init__(self) -> None:
        if not 1 <= self.sites <= MAX_SITES:
            raise ValueError(f"sites must be in [1, {MAX_SITES}], got {self.sites}")
        if not 1 <= self.followers <= MAX_FOLLOWERS:
            raise ValueError(f"followers must be in [1, {MAX_FOLLOWERS}] per site, "
                             f"got {self.followers}")
        for name in ("duration", "warmup"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be > 0 seconds, got {value!r}")
        if self.frame_bytes < FRAME_HEADER_BYTES:
            raise ValueError(f"frame_bytes must be >= {FRAME_HEADER_BYTES} (the frame's "
                             f"counter and capture time), got {self.frame_bytes}")
        bad = [k for k in self.in_flight or () if k != "auto" and not 1 <= k <= self.pairs]
        if bad:
            raise ValueError(f"in_flight must each be in [1, {self.pairs}] (one per "
                             f"(site, follower) pair at most), got {bad[0]}")

    @property
    def pairs(self) -> int:
        """(site, follower) pairs: what the cloud polls."""
        return self.sites * self.followers

    def frame_time(self, rate_bps: int) -> float:
        """One frame's time on a link of ``rate_bps``, headers included."""
        return self.frame_bytes * 8 * FRAME_OVERHEAD / rate_bps

    def wan_in_flight(self) -> int:
        """Polls in flight that keep the WAN busy: a poll is out for a round trip
        (2d + one frame's time on the WAN), the WAN is busy for the frame's time."""
        s_wan = self.frame_time(self.wan.rate_bps)
        return min(self.pairs, math.ceil((2 * self.wan.delay_s + s_wan) / s_wan))

    def setups(self) -> list[Setup]:
        ks = self.in_flight or tuple(dict.fromkeys((1, self.wan_in_flight(), self.pairs,
                                                    "auto")))
        direct = [] if self.secure else [Setup("direct")]
        return [*direct, *(Setup("hierarchy", k) for k in ks), Setup("edge")]

    @property
    def ids(self) -> list[str]:
        """Each site's follower ids."""
        return [f"uav{i}" for i in range(self.followers)]

    def pair_names(self, sites: list[Site]) -> list[str]:
        """``<site>.<follower>``, sites interleaved."""
        return [f"{s.name}.uav{i}" for i in range(self.followers) for s in sites]


@dataclass
class SetupResult:
    """What one setup measured: AoI per pair where it is measured (the cloud; the edge
    for ``edge``), the edges' own view meanwhile, the WAN's use, the least age seen."""

    setup: Setup
    window_s: float
    measured: list[FollowerMetrics]
    at_edge: list[FollowerMetrics]
    wan_up_mbps: float
    wan_down_mbps: float
    least_age_s: float  # the youngest update delivered in the window (inf: none)
    events: list[str] = field(default_factory=list)
    failed: int = 0  # processes that ended during the setup or not cleanly at its end

    def mean(self, name: str, at_edge: bool = False) -> float:
        rows = self.at_edge if at_edge else self.measured
        return sum(float(getattr(f, name)) for f in rows) / len(rows) if rows else math.nan


@dataclass
class EdgeCloudResults:
    config: EdgeCloudConfig
    results: list[SetupResult] = field(default_factory=list)
    interrupted: bool = False


Progress = Callable[[int, int], None]


def _swarms(setup: Setup, site: Site, specs: Specs) -> tuple[str, str]:
    """(the site's swarm, the cloud's swarm), unique to the setup but where the
    deployment's rules name them."""
    if specs.secure:
        return site.name, CLOUD
    if setup.kind == "direct":
        return "ec-d", "ec-d"
    return f"ec-{setup.tag}-{site.name}", f"ec-{setup.tag}-c"


class Layers:
    """A setup's children in three layers, stopped top down (cloud, edges, followers):
    no leader sees its followers vanish, nor an edge its cloud, as a setup ends. The
    links' children (routers, relays: ``links``) are watched with them, not stopped."""

    def __init__(self, stack: contextlib.ExitStack, links: Children,
                 link_names: list[str]) -> None:
        ctx = multiprocessing.get_context("spawn")
        self.order = [stack.enter_context(Children(ctx)) for _ in range(3)]
        self.owner: dict[str, Children] = dict.fromkeys(link_names, links)
        self._links = links

    def start(self, layer: int, name: str, *args: Any) -> None:
        self.owner[name] = self.order[layer]
        self.order[layer].start(name, *args, wait=False)

    def wait_ready(self) -> None:
        for children in self.order:
            children.wait_ready(READY_TIMEOUT)

    def ended(self) -> list[str]:
        return [name for name, owner in self.owner.items() if not owner.alive(name)]

    def exit_code(self, name: str) -> int | None:
        return self.owner[name].exit_code(name)

    def stopped_badly(self) -> list[str]:
        """Once the setup's own children are stopped (the links' run on): how each one
        that did not end cleanly ended."""
        return [ending(name, code) for name, owner in self.owner.items()
                if owner is not self._links and (code := owner.exit_code(name)) != 0]

    def restart(self, name: str) -> None:
        self.owner[name].restart(name, wait=False)
        self.owner[name].wait_ready(READY_TIMEOUT)


def _start_site(layers: Layers, config: EdgeCloudConfig, setup: Setup, site: Site,
                records: Path, specs: Specs) -> None:
    """The site's followers and, but for ``direct``, its edge leader."""
    swarm, cloud = _swarms(setup, site, specs)
    ids = config.ids
    named = [f"{site.name}.{f}" for f in ids] if setup.kind == "direct" else ids
    followers = [FollowerOptions(swarm, fid, frame_bytes=config.frame_bytes,
                                 frame_rate=SAMPLE_RATE,
                                 config_file=specs.follower_config(site, fid)) for fid in named]
    layers.start(FOLLOWERS, f"followers-{site.name}", run_in, site.channel.follower_ns,
                 run_followers, specs.followers(site), followers)
    if setup.kind == "direct":
        return
    parents = () if setup.kind == "edge" else tuple(
        (f, cloud) for f in ids)
    edge = LeadersOptions((swarm,), str(records / f"{setup.tag}-edge-{site.name}.csv"),
                          expect=tuple(f"{site.name}.{f}" for f in ids),
                          prefix=f"{site.name}.", parents=parents, site=site.name,
                          name=f"edge-{site.name}")
    layers.start(EDGES, f"edge-{site.name}", run_in, site.channel.leader_ns, run_leaders,
                 specs.leader(site), edge)


def _start(layers: Layers, net: EdgeCloud, config: EdgeCloudConfig, setup: Setup,
           records: Path, specs: Specs) -> list[str]:
    """Followers, edge leaders and cloud leaders of ``setup``, ready once every pair has
    been delivered where it is measured; returns the pair names."""
    pairs = config.pair_names(net.sites)
    for site in net.sites:
        _start_site(layers, config, setup, site, records, specs)
    if setup.kind != "edge":
        swarm, cloud = _swarms(setup, net.sites[0], specs)
        leaders = LeadersOptions((swarm if setup.kind == "direct" else cloud,),
                                 str(records / f"{setup.tag}-cloud.csv"),
                                 expect=tuple(pairs), name="cloud", in_flight=setup.k)
        layers.start(CLOUD_LAYER, "cloud", run_in, net.cloud_ns, run_leaders,
                     specs.leader(None), leaders)
    layers.wait_ready()
    return pairs


def _least_age(rows: dict[str, list[tuple[float, float]]], t0: float, t1: float) -> float:
    return min((d - g for deliveries in rows.values() for d, g in deliveries
                if t0 <= d <= t1), default=math.inf)


def measure_setup(net: EdgeCloud, links: tuple[Children, list[str]], config: EdgeCloudConfig,
                  setup: Setup, records: Path, stop: threading.Event,
                  tick: Callable[[float], None], specs: Specs) -> SetupResult:
    """Run ``setup`` for its warm-up and window; ``tick(fraction done)`` as it goes; a
    set ``stop`` ends the window early (what was measured is kept). A process that ends
    (``links`` too: routers, relays) is started again, and the event noted."""
    events: list[str] = []
    log.info("edge-cloud: %s starting", setup.label)
    with contextlib.ExitStack() as stack:
        layers = Layers(stack, *links)
        pairs = _start(layers, net, config, setup, records, specs)
        started = time.time()
        t0, t1 = started + config.warmup, started + config.warmup + config.duration
        before = None
        try:
            while (now := time.time()) < t1 and not stop.wait(min(SUPERVISE_PERIOD,
                                                                  t1 - now)):
                if before is None and time.time() >= t0:
                    before = _wan(net)
                tick((time.time() - started) / (t1 - started))
                for name in layers.ended():
                    events.append(f"t={time.time() - started:.1f}s: "
                                  f"{ending(name, layers.exit_code(name), early=True)}; "
                                  "started again")
                    log.warning("%s: %s", setup.label, events[-1])
                    layers.restart(name)
        except KeyboardInterrupt:  # Ctrl-C: this setup ends here, what it measured stays
            stop.set()
        end = min(time.time(), t1)
        after = _wan(net)
    stopping = layers.stopped_badly()
    failed = len(events) + len(stopping)  # every event so far was a process that ended
    events += [f"t={time.time() - started:.1f}s, stopping: {e}" for e in stopping]
    span = max(0.0, end - t0)
    edge_rows: dict[str, list[tuple[float, float]]] = {}
    for site in net.sites:
        edge_rows.update(read_record(records / f"{setup.tag}-edge-{site.name}.csv"))
    measured_rows = edge_rows if setup.kind == "edge" else read_record(
        records / f"{setup.tag}-cloud.csv")
    window = (started, t0, max(end, t0), config.frame_bytes)
    up = down = 0.0
    if before is not None and span > 0:
        up = sum(a[0] - b[0] for a, b in zip(after, before, strict=True)) * 8 / span / 1e6
        down = sum(a[1] - b[1] for a, b in zip(after, before, strict=True)) * 8 / span / 1e6
    return SetupResult(
        setup, span, window_metrics(measured_rows, pairs, *window),
        [] if setup.kind == "direct" else window_metrics(edge_rows, pairs, *window),
        up, down, _least_age(measured_rows, t0, end), events, failed)


def _wan(net: EdgeCloud) -> list[tuple[int, int]]:
    """Bytes sent so far on each site's WAN link: (up, down)."""
    return [(net.wan_up(s).sent_bytes, net.wan_down(s).sent_bytes) for s in net.sites]


def start_links(children: Children, net: EdgeCloud, specs: Specs) -> list[str]:
    """The cloud router, the relays, then the site routers (which dial the cloud);
    returns the children's names."""
    names = ["cloud-router"]
    children.start(names[-1], run_in, net.cloud_ns, run_router, specs.cloud_router(),
                   wait=False)
    for ns, hops in net.relays().items():
        names.append(f"relays-{ns}")
        children.start(names[-1], run_in, ns, run_relays, hops, wait=False)
    children.wait_ready()
    for site in net.sites:
        names.append(f"router-{site.name}")
        children.start(names[-1], run_in, site.channel.leader_ns, run_router,
                       specs.site_router(site), wait=False)
    children.wait_ready()
    return names


def _redraw(progress: Progress, done: int, total: int, _fraction: float) -> None:
    progress(done, total)  # the bar's clock moves on


def run_edge_cloud(config: EdgeCloudConfig, records: Path, progress: Progress,
                   stop: threading.Event | None = None) -> EdgeCloudResults:
    """Build the topology, measure every setup in turn, remove it; Ctrl-C (or ``stop``)
    ends the setup in progress, keeps what was measured and marks it ``interrupted``."""
    stop = stop or threading.Event()
    results = EdgeCloudResults(config)
    setups = config.setups()
    records.mkdir(parents=True, exist_ok=True)
    progress(0, len(setups))
    try:
        with EdgeCloud(config.sites, config.local, config.wan) as net, \
                tempfile.TemporaryDirectory() as tmp, \
                Children(multiprocessing.get_context("spawn")) as links:
            log.info("%s", net.describe())
            specs = Specs(net, config.ids, Path(tmp) / "pki" if config.secure else None)
            link_names = start_links(links, net, specs)
            for done, setup in enumerate(setups):
                if stop.is_set():
                    break
                tick = functools.partial(_redraw, progress, done, len(setups))
                result = measure_setup(net, (links, link_names), config, setup, records,
                                       stop, tick, specs)
                if result.window_s > 0:
                    results.results.append(result)
                progress(done + 1, len(setups))
    except KeyboardInterrupt:
        stop.set()
    results.interrupted = stop.is_set()
    return results
