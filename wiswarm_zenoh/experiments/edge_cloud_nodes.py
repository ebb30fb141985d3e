"""The processes of the edge-cloud testbed that ``runners`` has no program for: the
WAN's relay hops, and leaders as the experiment needs them.

``run_leaders`` runs one ``LeaderNode`` per swarm on one session. An edge runs one (its
site's swarm) and hands deliveries upstream, as ``wiswarm leader --upstream`` does; the
cloud leader keeps ``in_flight`` polls out (``wiswarm leader --in-flight``). The process
says it is ready once every follower it expects has been delivered: a run's warm-up
then starts from a swarm that works end to end, with no guessed sleep.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

from wiswarm_zenoh.core import Delivered, LeaderConfig
from wiswarm_zenoh.core.config import InFlight
from wiswarm_zenoh.experiments.edge_cloud_topology import RelaySpec
from wiswarm_zenoh.programs.delivery_csv import DeliveryRecord
from wiswarm_zenoh.programs.frames import capture_time
from wiswarm_zenoh.programs.runners import (
    ReadySignal,
    StopSignal,
    wait_until_stopped,
)
from wiswarm_zenoh.testbed.relay import DelayRelay
from wiswarm_zenoh.transport.edge import Upstream
from wiswarm_zenoh.transport.leader_node import LeaderNode
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

log = logging.getLogger(__name__)

MISSING_AFTER = 10.0  # seconds: then say which expected followers were never delivered


def run_relays(hops: Sequence[RelaySpec], stop: StopSignal,
               ready: ReadySignal | None = None) -> None:
    """The relay hops of one namespace until stopped; what each carried is logged."""
    with contextlib.ExitStack() as stack:
        relays = [stack.enter_context(DelayRelay(hop.listen, hop.target, hop.delay,
                                                 delay_back=hop.delay_back)) for hop in hops]
        if ready is not None:
            ready.set()
        wait_until_stopped(stop)
        for relay in relays:
            c = relay.counters()
            log.info("relay to %s:%d: %d bytes there, %d back, %d connections, latest write "
                     "%.2f ms after due", *relay.target, c.to_target_bytes,
                     c.from_target_bytes, c.connections, c.max_lateness_s * 1e3)


@dataclass(frozen=True)
class LeadersOptions:
    """Leaders of one process: ``swarms`` (one LeaderNode each); ``record``, a CSV of
    every delivery (capture stamps: one host clock), followers named ``prefix`` +
    their id; ready once each of ``expect`` (so named) was delivered. An edge (one
    swarm) serves ``parents``: (follower, parent swarm) pairs, as site ``site``."""

    swarms: tuple[str, ...]
    record: str
    expect: tuple[str, ...]
    prefix: str = ""
    parents: tuple[tuple[str, str], ...] = ()
    site: str | None = None
    name: str = "leader"
    in_flight: InFlight = 1

    def __post_init__(self) -> None:
        if self.parents and (len(self.swarms) != 1 or self.site is None):
            raise ValueError("an edge leads one swarm and names its site")


class Progress:
    """Which expected followers have been delivered; sets ``ready`` when all have."""

    def __init__(self, expect: Sequence[str], ready: ReadySignal | None) -> None:
        self.missing = set(expect)
        self._ready = ready
        self._lock = threading.Lock()
        if not self.missing and ready is not None:
            ready.set()

    def delivered(self, follower: str) -> None:
        with self._lock:
            if follower not in self.missing:
                return
            self.missing.discard(follower)
            done = not self.missing
        if done and self._ready is not None:
            self._ready.set()


def run_leaders(spec: SessionSpec, options: LeadersOptions, stop: StopSignal,
                ready: ReadySignal | None = None) -> None:
    """The leaders of ``options`` until stopped (see the module's docstring)."""
    record = DeliveryRecord(options.record)
    lock = threading.Lock()  # the record, written from every leader's poll thread
    progress = Progress(options.expect, ready)
    parent_of = dict(options.parents)
    try:
        with spec.open() as session, contextlib.ExitStack() as stack:
            upstreams = {parent: Upstream(session, parent, options.site or "")
                         for parent in sorted(set(parent_of.values()))}
            for upstream in upstreams.values():
                stack.callback(upstream.close)

            def upstream_of(follower: str) -> Upstream | None:
                return upstreams.get(parent_of.get(follower, ""))

            def on_delivery(event: Delivered) -> None:
                name = options.prefix + event.follower
                with lock:
                    record.row(name, event.update_seq, capture_time(event.payload),
                               event.delivered_at, len(event.payload))
                progress.delivered(name)
                upstream = upstream_of(event.follower)
                if upstream is not None:
                    upstream.on_delivery(event)

            def on_join(follower: str) -> None:
                upstream = upstream_of(follower)
                if upstream is not None:
                    upstream.on_join(follower)

            def on_leave(follower: str) -> None:
                upstream = upstream_of(follower)
                if upstream is not None:
                    upstream.on_leave(follower)

            def on_role(active: bool) -> None:
                for upstream in upstreams.values():
                    upstream.on_role(active)

            config = LeaderConfig(in_flight=options.in_flight)
            nodes = [stack.enter_context(LeaderNode(
                session, swarm, config, on_delivery=on_delivery, on_join=on_join,
                on_leave=on_leave, on_role=on_role, name=f"{options.name}-{i}"))
                for i, swarm in enumerate(options.swarms)]
            for upstream in upstreams.values():
                upstream.set_control = nodes[0].set_control
            started = time.monotonic()
            said = [False]

            def tick() -> None:
                if not said[0] and progress.missing and time.monotonic() - started > \
                        MISSING_AFTER:
                    said[0] = True
                    log.warning("%s: nothing delivered yet from %s", options.name,
                                ", ".join(sorted(progress.missing)))

            wait_until_stopped(stop, tick=tick)
    finally:
        record.close()
