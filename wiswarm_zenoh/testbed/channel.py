"""The emulated shared channel: two network namespaces joined by one veth pair, each
end's egress shaped by ``tc tbf`` (``netem`` is not available everywhere; tbf is).

The follower side's end carries every follower's frames to the leader side: that tbf
is the shared uplink, the bottleneck the polling schedules. The leader side's end
carries polls and control back, shaped too because they share the same air. One
process's flows can be capped inside the uplink (``cap_flows_of``: a robot whose link
degrades), by an htb under its tbf.

Nothing outside the two namespaces a channel creates is touched. Every channel has a
small record under ``/run/wiswarm-testbed`` naming the process that owns it, so the
next build removes channels whose process died without cleaning up (SIGKILL);
channels made by ``wiswarm testbed up`` are persistent and kept until ``down``.
"""

from __future__ import annotations

import itertools
import logging
import os
import re
from dataclasses import dataclass, replace
from types import TracebackType

from wiswarm_zenoh.testbed.channel_records import (
    FOLLOWER_IF,
    LEADER_IF,
    STATE_DIR,
    ChannelRecord,
    cleanup_locked,
    list_channels,
    namespaces,
    record_path,
    remove_locked,
)
from wiswarm_zenoh.testbed.flows import Flow, tcp_flows
from wiswarm_zenoh.testbed.ownership import (
    locked,
    namespace_exists,
    process_start,
)
from wiswarm_zenoh.testbed.spec import (
    DEFAULT_SPEC,
    MTU,
    ChannelSpec,
    LinkCounters,
    check_available,
)
from wiswarm_zenoh.testbed.tc import (
    UNCAPPED,
    add_htb,
    class_counters,
    counters,
    remove_class,
    run,
    run_json,
    set_class,
    set_queue,
    spec_from_tc,
    steer,
    tbf_args,
    tbf_qdisc,
    unsteer,
)
from wiswarm_zenoh.units import MAX_RATE_BPS, MIN_RATE_BPS, format_rate

log = logging.getLogger(__name__)

SUBNETS = range(1, 255)  # channel k: leader 10.201.k.1, follower 10.201.k.2 (/24)
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,23}$")
_counter = itertools.count()


@dataclass(frozen=True)
class _Cap:
    """One process's flows in htb class ``k`` of the uplink."""

    k: int
    rate_bps: int
    flows: list[Flow]


def _addresses(subnet: int) -> tuple[str, str]:
    return f"10.201.{subnet}.1", f"10.201.{subnet}.2"


class Channel:
    """One emulated shared link; a context manager that builds it and removes it.

    ``name`` chooses the run id (letters, digits, ``-``, ``_``); by default it is the
    process id in hex and a counter, unique among present channels.
    """

    run_id: str
    leader_ns: str
    follower_ns: str
    leader_addr: str
    follower_addr: str

    def __init__(self, spec: ChannelSpec = DEFAULT_SPEC, name: str | None = None) -> None:
        if name is not None and not _NAME.match(name):
            raise ValueError(f"channel name {name!r}: use 1-24 letters, digits, '-' or '_'")
        self.spec = spec
        self.persistent = False
        self.owner_pid: int | None = os.getpid()  # None: unknown (a channel without record)
        self._name = name
        self._built = False
        self._htb = False  # the uplink's htb for capped flows, built at the first cap
        self._caps: dict[int, _Cap] = {}  # by process id

    def __enter__(self) -> Channel:
        return self.build()

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def _place(self, run_id: str, subnet: int) -> None:
        self.run_id = run_id
        self.leader_ns, self.follower_ns = namespaces(run_id)
        self.leader_addr, self.follower_addr = _addresses(subnet)

    def build(self, *, persistent: bool = False) -> Channel:
        """Create namespaces, veth, addresses and shapers (once; later calls return self).

        ``persistent`` channels outlive this process (``wiswarm testbed up``) and are
        never taken for leftovers; others are removed by ``close``, or by the next
        build anywhere once this process is gone.
        """
        if self._built:
            return self
        check_available()
        with locked(STATE_DIR):
            cleanup_locked()
            run_id = self._name or self._fresh_id()
            if self._name is not None and (run_id in list_channels()
                                           or record_path(run_id).exists()):
                raise ValueError(f"a testbed channel named {run_id!r} exists already")
            used = {record.subnet for record in map(ChannelRecord.load, list_channels())
                    if record is not None}
            subnet = next((k for k in SUBNETS if k not in used), None)
            if subnet is None:
                raise RuntimeError(f"all {len(SUBNETS)} testbed subnets are in use: "
                                   "remove channels with `wiswarm testbed down`")
            self._place(run_id, subnet)
            self.persistent = persistent
            owner = 0 if persistent else os.getpid()
            start = 0 if persistent else process_start(owner)
            ChannelRecord(run_id, owner, start or 0, subnet, self.spec).save()
            self.persistent, self.owner_pid = persistent, owner
            try:
                self._create()
            except BaseException:
                remove_locked(run_id)
                raise
        self._built = True
        log.info("testbed channel %s up: %s up, %s down, queue %g ms", self.run_id,
                 format_rate(self.spec.rate_bps), format_rate(self.spec.down_bps),
                 self.spec.queue_s * 1e3)
        return self

    @staticmethod
    def _fresh_id() -> str:
        taken = set(list_channels())
        while True:
            run_id = f"{os.getpid():x}-{next(_counter)}"
            if run_id not in taken and not record_path(run_id).exists():
                return run_id

    def _create(self) -> None:
        ends = ((self.leader_ns, LEADER_IF, self.leader_addr, self.spec.down_bps),
                (self.follower_ns, FOLLOWER_IF, self.follower_addr, self.spec.rate_bps))
        for ns, *_ in ends:
            run("ip", "netns", "add", ns)
        run("ip", "-n", self.leader_ns, "link", "add", LEADER_IF, "type", "veth",
             "peer", "name", FOLLOWER_IF, "netns", self.follower_ns)
        for ns, ifname, addr, rate in ends:
            # One MTU-sized packet per skb: without this, TCP hands tbf 64 kB GSO
            # super-packets, which leave as bursts far above the rate. No IPv6 link-local
            # address: its neighbour discovery would be traffic nobody asked for.
            run("ip", "-n", ns, "link", "set", "dev", ifname, "mtu", str(MTU),
                 "gso_max_size", str(MTU), "gso_max_segs", "1", "addrgenmode", "none")
            run("ip", "-n", ns, "addr", "add", f"{addr}/24", "dev", ifname)
            run("tc", "-n", ns, "qdisc", "replace", "dev", ifname, "root",
                 *tbf_args(rate, self.spec))
            run("ip", "-n", ns, "link", "set", "dev", "lo", "up")
            run("ip", "-n", ns, "link", "set", "dev", ifname, "up")

    def close(self) -> None:
        """Remove the channel (veth and qdiscs, namespaces, record); safe to repeat."""
        if not self._built:
            return
        with locked(STATE_DIR):
            remove_locked(self.run_id)
        self._built = False
        log.info("testbed channel %s removed", self.run_id)

    def _require_built(self) -> None:
        if not self._built:
            raise RuntimeError("the channel is not built: use `with Channel() as ch` or build()")

    def set_rate(self, rate_bps: int, down_rate_bps: int | None = None) -> None:
        """Change the rates mid-run (``tc qdisc change``; queued packets stay queued).
        ``down_rate_bps`` None makes the downlink's rate the uplink's, as in ChannelSpec."""
        self._require_built()
        spec = replace(self.spec, rate_bps=rate_bps, down_rate_bps=down_rate_bps)
        for ns, ifname, old, new in (
                (self.follower_ns, FOLLOWER_IF, self.spec.rate_bps, spec.rate_bps),
                (self.leader_ns, LEADER_IF, self.spec.down_bps, spec.down_bps)):
            if new != old:
                run("tc", "-n", ns, "qdisc", "change", "dev", ifname, "root",
                     *tbf_args(new, spec))
        if self._htb and spec.rate_bps != self.spec.rate_bps:
            set_queue(self.follower_ns, FOLLOWER_IF, UNCAPPED, spec.limit_bytes(spec.rate_bps))
        self.spec = spec
        with locked(STATE_DIR):
            record = ChannelRecord.load(self.run_id)
            if record is not None:
                replace(record, spec=spec).save()
        log.info("testbed channel %s: rate now %s up, %s down", self.run_id,
                 format_rate(spec.rate_bps), format_rate(spec.down_bps))

    def cap_flows_of(self, pid: int, rate_bps: int) -> list[Flow]:
        """Cap process ``pid``'s share of the uplink at ``rate_bps`` while the uplink
        keeps its own rate: one robot's link degraded, the robot being a process in the
        follower side's namespace (its router, connected to the ground's). Its TCP
        connections from the follower side, as they are now, go into an htb class of
        that rate with a queue of the channel's latency at it (the htb is built under the
        tbf at the first cap). A connection it opens later is not capped: cap again,
        which also changes the rate. Returns the flows capped; ValueError if the rate is
        out of range or the process has no connection across the channel."""
        self._require_built()
        if not (isinstance(rate_bps, int) and MIN_RATE_BPS <= rate_bps <= MAX_RATE_BPS):
            raise ValueError(f"a cap must be a whole number of bits/s between "
                             f"{format_rate(MIN_RATE_BPS)} and {format_rate(MAX_RATE_BPS)}, "
                             f"got {rate_bps!r}")
        flows = tcp_flows(pid, self.follower_addr)
        if not flows:
            raise ValueError(f"process {pid} has no TCP connection from the follower side "
                             f"({self.follower_addr}) of channel {self.run_id} to cap")
        if not self._htb:
            add_htb(self.follower_ns, FOLLOWER_IF, self.spec, self.spec.rate_bps)
            self._htb = True
        was = self._caps.get(pid)
        k = was.k if was else next(k for k in itertools.count(UNCAPPED + 1)
                                   if k not in {cap.k for cap in self._caps.values()})
        set_class(self.follower_ns, FOLLOWER_IF, k, rate_bps, self.spec.limit_bytes(rate_bps),
                  self.spec)
        if was:
            unsteer(self.follower_ns, FOLLOWER_IF, k)
        steer(self.follower_ns, FOLLOWER_IF, k, flows)
        self._caps[pid] = _Cap(k, rate_bps, flows)
        log.info("testbed channel %s: process %d's %d flow(s) capped at %s", self.run_id,
                 pid, len(flows), format_rate(rate_bps))
        return flows

    def uncap(self, pid: int) -> None:
        """Process ``pid``'s flows back to the uplink's full share (packets still queued
        in its cap are lost; TCP sends them again). ValueError if it is not capped."""
        cap = self._cap(pid)
        unsteer(self.follower_ns, FOLLOWER_IF, cap.k)
        remove_class(self.follower_ns, FOLLOWER_IF, cap.k)
        del self._caps[pid]
        log.info("testbed channel %s: process %d's flows uncapped", self.run_id, pid)

    def cap_counters(self, pid: int) -> LinkCounters:
        """What process ``pid``'s cap let through and dropped since it was first set."""
        return class_counters(self.follower_ns, FOLLOWER_IF, self._cap(pid).k)

    def _cap(self, pid: int) -> _Cap:
        self._require_built()
        if pid not in self._caps:
            raise ValueError(f"process {pid}'s flows are not capped on channel {self.run_id}")
        return self._caps[pid]

    def uplink(self) -> LinkCounters:
        """The followers -> leader direction (the follower side's tbf)."""
        self._require_built()
        return counters(self.follower_ns, FOLLOWER_IF)

    def downlink(self) -> LinkCounters:
        """The leader -> followers direction (the leader side's tbf)."""
        self._require_built()
        return counters(self.leader_ns, LEADER_IF)

    def describe(self) -> str:
        """What the channel is and who runs where, for people."""
        self._require_built()
        spec = self.spec
        owner = ("persistent (until `wiswarm testbed down`)" if self.persistent
                 else "owner unknown" if self.owner_pid is None
                 else f"owned by pid {self.owner_pid}")
        return "\n".join((
            f"testbed channel {self.run_id}, {owner}",
            f"  uplink (followers -> leader): {format_rate(spec.rate_bps)}, "
            f"tbf on {FOLLOWER_IF} in {self.follower_ns}",
            f"  downlink (leader -> followers): {format_rate(spec.down_bps)}, "
            f"tbf on {LEADER_IF} in {self.leader_ns}",
            f"  queue: {spec.queue_s * 1e3:g} ms each way (tbf latency), "
            f"burst {spec.burst_bytes} bytes, MTU {MTU}",
            f"  leader side: router + leader in {self.leader_ns} at {self.leader_addr}",
            f"  follower side: followers in {self.follower_ns} at {self.follower_addr}",
            *(f"  process {pid}'s {len(cap.flows)} flow(s) capped at "
              f"{format_rate(cap.rate_bps)}" for pid, cap in self._caps.items()),
        ))

    @classmethod
    def attach(cls, run_id: str) -> Channel:
        """The present channel ``run_id`` (made by any process), its spec read from tc;
        LookupError if it does not exist. Closing it removes the channel."""
        leader_ns, follower_ns = namespaces(run_id)
        if not (namespace_exists(leader_ns) and namespace_exists(follower_ns)):
            raise LookupError(f"no testbed channel {run_id!r}")
        record = ChannelRecord.load(run_id)
        up, down = tbf_qdisc(follower_ns, FOLLOWER_IF), tbf_qdisc(leader_ns, LEADER_IF)
        channel = cls(spec_from_tc(up["options"], down["options"],
                                    None if record is None else record.spec))
        if record is not None:
            channel._place(run_id, record.subnet)
            channel.persistent, channel.owner_pid = record.persistent, record.owner_pid
        else:
            channel.run_id, channel.leader_ns, channel.follower_ns = run_id, *namespaces(run_id)
            channel.leader_addr = _address(leader_ns, LEADER_IF)
            channel.follower_addr = _address(follower_ns, FOLLOWER_IF)
            channel.owner_pid = None
        channel._built = True
        return channel


def _address(ns: str, ifname: str) -> str:
    for link in run_json("ip", "-n", ns, "-4", "-j", "addr", "show", "dev", ifname):
        for info in link.get("addr_info", []):
            return str(info["local"])
    raise RuntimeError(f"{ifname} in namespace {ns} has no IPv4 address")
