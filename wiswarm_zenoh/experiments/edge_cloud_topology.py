"""The edge-cloud testbed's network: sites, each a shared channel of its own, joined to
a cloud namespace by wide-area links between Zenoh routers.

Site k (1-based) is a testbed ``Channel``: followers in its follower namespace, its
router and edge leader in its leader namespace (``10.201.x.1`` on the channel's veth).
A second veth pair, the WAN link, joins that leader namespace (``wsw-W``,
``10.202.k.2``) to the cloud namespace (``wsw-Ck``, ``10.202.k.1``); each end's egress
is shaped by ``tc tbf`` at the WAN's rate, as the channel's are. ``netem`` is absent,
so the one-way delay is added by two ``DelayRelay`` hops, each placed *after* the tbf
of the direction it delays (where bytes come at the link's rate, see ``relay``):

    site router -> 127.0.0.1:7461 (site relay: 0 up, d down) -> tbf -> WAN veth
      -> 10.202.k.1:7460 (cloud relay: d up, 0 down) -> 127.0.0.1:7447 cloud router

Site routers dial out to the cloud, as edge sites do behind NAT. Everything a run
leaves is removed by ``close``; a record under ``/run/wiswarm-testbed/edge-cloud``
names the owning process, so the next build removes what a killed owner left (the
site channels also have their own records, see ``channel``).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import logging
import math
import os
from dataclasses import dataclass
from types import TracebackType

from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.channel_records import STATE_DIR, remove_channel
from wiswarm_zenoh.testbed.netns import NETNS_DIR
from wiswarm_zenoh.testbed.nodes import NO_SHARED_MEMORY, ROUTER_PORT, Placement
from wiswarm_zenoh.testbed.ownership import locked, namespace_exists, process_start
from wiswarm_zenoh.testbed.spec import MTU, ChannelSpec, LinkCounters, check_available
from wiswarm_zenoh.testbed.tc import counters, run, run_json, tbf_args
from wiswarm_zenoh.transport.zenoh_config import SessionSpec
from wiswarm_zenoh.units import format_rate

log = logging.getLogger(__name__)

RECORDS = STATE_DIR / "edge-cloud"  # not STATE_DIR itself: channel.py prunes its *.json
CLOUD_SUFFIX = "-C"
SITE_WAN_IF = "wsw-W"
CLOUD_RELAY_PORT = 7460  # on each WAN link's cloud address
SITE_RELAY_PORT = 7461  # on each site's loopback: its router connects here
LOOPBACK = "127.0.0.1"
MAX_SITES = 99  # interface names wsw-C1 .. wsw-C99, subnets 10.202.1-99
MAX_DELAY_S = 10.0
_counter = itertools.count()

Address = tuple[str, int]


@dataclass(frozen=True)
class WanSpec:
    """A wide-area link: its rate each way (bits/s), one-way delay, tbf queue and burst."""

    rate_bps: int = 50_000_000
    delay_s: float = 0.02
    queue_s: float = 0.2
    burst_bytes: int = 32 * 1024

    def __post_init__(self) -> None:
        self.shaping()  # the tbf's own checks, naming the field
        if not (isinstance(self.delay_s, int | float) and math.isfinite(self.delay_s)
                and 0 < self.delay_s <= MAX_DELAY_S):
            raise ValueError(f"delay_s must be in (0, {MAX_DELAY_S:g}] seconds, "
                             f"got {self.delay_s!r}")

    def shaping(self) -> ChannelSpec:
        """The tbf of each end, as the channel's."""
        return ChannelSpec(rate_bps=self.rate_bps, queue_s=self.queue_s,
                           burst_bytes=self.burst_bytes)


@dataclass(frozen=True)
class RelaySpec:
    """One relay hop: accept on ``listen``, relay to ``target``, holding bytes
    ``delay`` seconds on the way there and ``delay_back`` on the way back."""

    listen: Address
    target: Address
    delay: float
    delay_back: float


def client_of_local_router() -> SessionSpec:
    """A leader beside its namespace's router: a client (it talks to that router only,
    so no gossip sends it looking for peers in other namespaces)."""
    return SessionSpec(mode="client", connect=(f"tcp/{LOOPBACK}:{ROUTER_PORT}",),
                       cfg=(NO_SHARED_MEMORY,), multicast_scouting=False)


@dataclass(frozen=True)
class Site:
    """One site: its channel and the site end of its WAN link."""

    name: str  # s1, s2, ...
    index: int
    channel: Channel

    @property
    def wan_cloud_addr(self) -> str:
        return f"10.202.{self.index}.1"

    @property
    def wan_site_addr(self) -> str:
        return f"10.202.{self.index}.2"

    @property
    def cloud_if(self) -> str:
        return f"wsw-C{self.index}"

    @property
    def placement(self) -> Placement:
        ch = self.channel
        return Placement(ch.leader_ns, ch.follower_ns, ch.leader_addr)

    def router(self) -> SessionSpec:
        """Listens on the channel (followers) and loopback (edge leader); dials the
        cloud through the site relay."""
        return SessionSpec(mode="router", listen=(self.placement.router_endpoint,
                                                  f"tcp/{LOOPBACK}:{ROUTER_PORT}"),
                           connect=(f"tcp/{LOOPBACK}:{SITE_RELAY_PORT}",),
                           cfg=(NO_SHARED_MEMORY,), multicast_scouting=False)

    def relay(self, delay: float) -> RelaySpec:
        """Cloud -> site bytes are delayed here, after the cloud end's tbf."""
        return RelaySpec((LOOPBACK, SITE_RELAY_PORT), (self.wan_cloud_addr, CLOUD_RELAY_PORT),
                         0.0, delay)

    def cloud_relay(self, delay: float) -> RelaySpec:
        """Site -> cloud bytes are delayed in the cloud, after the site end's tbf."""
        return RelaySpec((self.wan_cloud_addr, CLOUD_RELAY_PORT), (LOOPBACK, ROUTER_PORT),
                         delay, 0.0)


def cloud_router() -> SessionSpec:
    """The cloud's router: the relays from every site and the cloud leaders connect here."""
    return SessionSpec(mode="router", listen=(f"tcp/{LOOPBACK}:{ROUTER_PORT}",),
                       cfg=(NO_SHARED_MEMORY,), multicast_scouting=False)


def _remove(record: dict[str, object]) -> None:
    """Remove a topology's WAN links, cloud namespace, site channels and record."""
    cloud_ns = str(record["cloud_ns"])
    if namespace_exists(cloud_ns):
        for link in run_json("ip", "-n", cloud_ns, "-j", "link", "show"):
            if str(link["ifname"]).startswith("wsw-C"):
                run("ip", "-n", cloud_ns, "link", "del", "dev", link["ifname"])  # and its peer
        run("ip", "netns", "del", cloud_ns)
    channels = record.get("channels")
    for run_id in channels if isinstance(channels, list) else []:
        with contextlib.suppress(LookupError):
            remove_channel(str(run_id))
    (RECORDS / f"{record['run_id']}.json").unlink(missing_ok=True)


def cleanup_leftovers() -> list[str]:
    """Remove the topologies whose owning process is gone, and cloud namespaces no
    record names (a record is written before its namespace is made); returns the run
    ids removed."""
    removed, kept = [], set()
    with locked(RECORDS):
        for path in sorted(RECORDS.glob("*.json")):
            try:
                record = json.loads(path.read_text())
                alive = process_start(int(record["owner_pid"])) == record["owner_start"]
            except (OSError, ValueError, KeyError, TypeError) as exc:
                log.warning("unreadable edge-cloud record %s (%s): removing it", path, exc)
                path.unlink(missing_ok=True)
                continue
            if alive:
                kept.add(str(record["cloud_ns"]))
                continue
            _remove(record)
            log.warning("removed leftover edge-cloud topology %s (its process, pid %s, is "
                        "gone)", record["run_id"], record["owner_pid"])
            removed.append(str(record["run_id"]))
        for path in NETNS_DIR.glob(f"wsw-ec*{CLOUD_SUFFIX}"):
            if path.name not in kept:
                run_id = path.name.removeprefix("wsw-").removesuffix(CLOUD_SUFFIX)
                _remove({"run_id": run_id, "cloud_ns": path.name})
                log.warning("removed edge-cloud namespace %s, which no record names",
                            path.name)
                removed.append(run_id)
    return removed


class EdgeCloud:
    """Sites and a cloud joined by WAN links; a context manager that builds and removes
    them. Processes (routers, relays, leaders) are the caller's: see ``edge_cloud_run``."""

    def __init__(self, sites: int, local: ChannelSpec, wan: WanSpec) -> None:
        if not 1 <= sites <= MAX_SITES:
            raise ValueError(f"sites must be in [1, {MAX_SITES}], got {sites}")
        self.local, self.wan, self.count = local, wan, sites
        self.run_id = f"ec{os.getpid():x}-{next(_counter)}"
        self.cloud_ns = f"wsw-{self.run_id}{CLOUD_SUFFIX}"
        self.sites: list[Site] = []
        self._built = False

    def __enter__(self) -> EdgeCloud:
        return self.build()

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def _record(self) -> dict[str, object]:
        pid = os.getpid()
        return {"run_id": self.run_id, "owner_pid": pid, "owner_start": process_start(pid),
                "cloud_ns": self.cloud_ns, "channels": [s.channel.run_id for s in self.sites]}

    def _save(self) -> None:
        path = RECORDS / f"{self.run_id}.json"
        path.with_suffix(".tmp").write_text(json.dumps(self._record(), indent=1) + "\n")
        os.replace(path.with_suffix(".tmp"), path)

    def build(self) -> EdgeCloud:
        """Channels, the cloud namespace and the WAN links (recorded before made)."""
        if self._built:
            return self
        check_available()
        cleanup_leftovers()
        with locked(RECORDS):
            self._save()
        self._built = True
        try:
            for index in range(1, self.count + 1):
                channel = Channel(self.local).build()
                self.sites.append(Site(f"s{index}", index, channel))
                with locked(RECORDS):
                    self._save()
            run("ip", "netns", "add", self.cloud_ns)
            run("ip", "-n", self.cloud_ns, "link", "set", "dev", "lo", "up")
            for site in self.sites:
                self._link(site)
        except BaseException:
            self.close()
            raise
        log.info("edge-cloud topology %s up: %d sites on %s channels, WAN %s and %g ms each "
                 "way", self.run_id, self.count, format_rate(self.local.rate_bps),
                 format_rate(self.wan.rate_bps), self.wan.delay_s * 1e3)
        return self

    def _link(self, site: Site) -> None:
        """The WAN veth between the site's leader namespace and the cloud, tbf each end."""
        site_ns = site.channel.leader_ns
        run("ip", "-n", self.cloud_ns, "link", "add", site.cloud_if, "type", "veth",
            "peer", "name", SITE_WAN_IF, "netns", site_ns)
        shaping = self.wan.shaping()
        for ns, ifname, addr in ((self.cloud_ns, site.cloud_if, site.wan_cloud_addr),
                                 (site_ns, SITE_WAN_IF, site.wan_site_addr)):
            # As channel.py: one MTU packet per skb, or tbf sees 64 kB bursts.
            run("ip", "-n", ns, "link", "set", "dev", ifname, "mtu", str(MTU),
                "gso_max_size", str(MTU), "gso_max_segs", "1", "addrgenmode", "none")
            run("ip", "-n", ns, "addr", "add", f"{addr}/24", "dev", ifname)
            run("tc", "-n", ns, "qdisc", "replace", "dev", ifname, "root",
                *tbf_args(self.wan.rate_bps, shaping))
            run("ip", "-n", ns, "link", "set", "dev", ifname, "up")

    def wan_up(self, site: Site) -> LinkCounters:
        """Site -> cloud: the site end's tbf."""
        return counters(site.channel.leader_ns, SITE_WAN_IF)

    def wan_down(self, site: Site) -> LinkCounters:
        """Cloud -> site: the cloud end's tbf."""
        return counters(self.cloud_ns, site.cloud_if)

    def relays(self) -> dict[str, list[RelaySpec]]:
        """Relay hops by namespace: one in each site, one per site in the cloud."""
        delay = self.wan.delay_s
        hops = {site.channel.leader_ns: [site.relay(delay)] for site in self.sites}
        hops[self.cloud_ns] = [site.cloud_relay(delay) for site in self.sites]
        return hops

    def close(self) -> None:
        """Remove everything built (safe to repeat, and after a failed build)."""
        if not self._built:
            return
        with locked(RECORDS):
            _remove(self._record())
        self.sites.clear()
        self._built = False
        log.info("edge-cloud topology %s removed", self.run_id)

    def describe(self) -> str:
        """Who runs where, for people."""
        lines = [f"edge-cloud topology {self.run_id}: cloud namespace {self.cloud_ns}, "
                 f"router on {LOOPBACK}:{ROUTER_PORT}"]
        for site in self.sites:
            ch = site.channel
            lines.append(
                f"  {site.name}: channel {ch.run_id} ({format_rate(self.local.rate_bps)}), "
                f"router + edge leader in {ch.leader_ns} at {ch.leader_addr}, followers in "
                f"{ch.follower_ns}; WAN {site.wan_site_addr} <-> {site.wan_cloud_addr} "
                f"({format_rate(self.wan.rate_bps)}, {self.wan.delay_s * 1e3:g} ms)")
        return "\n".join(lines)
