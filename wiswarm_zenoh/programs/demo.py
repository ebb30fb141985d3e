"""``wiswarm demo``: a router, a leader and synthetic followers as separate processes.

The parent only watches: it subscribes to the stats JSON like any other Zenoh tool,
shows the live table, and afterwards writes ``stats.csv`` and ``aoi.png`` (from the
leader's record of every delivery) under ``runs/<timestamp>/``. Children ignore Ctrl-C
(the parent stops each with SIGTERM) and stop by themselves if the parent dies, so no
process outlives the demo.
"""

from __future__ import annotations

import json
import logging
import multiprocessing
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from multiprocessing.context import SpawnContext, SpawnProcess
from multiprocessing.synchronize import Event as ProcessEvent
from pathlib import Path
from types import TracebackType
from typing import Any, TextIO

import zenoh

from wiswarm_zenoh.core import FollowerConfig, LeaderConfig
from wiswarm_zenoh.programs.frames import FRAME_BYTES, FRAME_RATE
from wiswarm_zenoh.programs.report import (
    LiveTable,
    PollRates,
    format_table,
    plot_aoi,
    read_deliveries,
    write_stats_csv,
)
from wiswarm_zenoh.programs.runners import (
    FollowerOptions,
    LeaderOptions,
    run_child,
    run_follower,
    run_leader,
    run_router,
    sigterm_as_ctrl_c,
)
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys
from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port

log = logging.getLogger(__name__)

READY_TIMEOUT = 30.0  # seconds for a child to open its session
READY_CHECK = 0.1  # seconds between checks that the children still starting are alive
STOP_TIMEOUT = 5.0  # seconds for a child to stop before it is killed
REFRESH = 0.25  # seconds between redraws of the live table


@dataclass(frozen=True)
class DemoOptions:
    followers: int = 6
    duration: float = 20.0
    policy: str = "whittle"
    frame_bytes: int = FRAME_BYTES
    frame_rate: float = FRAME_RATE
    out: str = "runs"
    swarm: str = "demo"


class Children:
    """Child processes (``spawn``) started by name and all stopped on exit: asked
    (SIGTERM; a child whose work is done ignores it and ends by itself, see
    ``run_child``), then killed if they do not end within STOP_TIMEOUT.

    ``start(..., wait=False)`` lets several children come up together; ``wait_ready``
    then waits for all of them.
    """

    def __init__(self, ctx: SpawnContext) -> None:
        self._ctx = ctx
        self._procs: dict[str, SpawnProcess] = {}
        self._targets: dict[str, tuple[Callable[..., object], tuple[Any, ...]]] = {}
        self._starting: list[tuple[SpawnProcess, ProcessEvent]] = []  # not yet ready
        self._stopped: set[str] = set()

    def start(self, name: str, target: Callable[..., object], *args: Any,
              wait: bool = True) -> None:
        """Start ``target(*args, stop, ready)`` as child ``name``; with ``wait``, return
        once it (and every child started before it) says it is ready."""
        if name in self._procs:
            raise ValueError(f"a child named {name!r} was already started")
        self._targets[name] = (target, args)
        self._launch(name, wait)

    def restart(self, name: str, wait: bool = True) -> None:
        """Start child ``name`` again, as it was first started (it has ended: a fault
        the run survives); its exit code is logged."""
        old = self._procs[name]
        if old.is_alive():
            raise ValueError(f"child {name!r} is still running")
        log.warning("%s ended (exit code %s): starting it again", name, old.exitcode)
        self._launch(name, wait)

    def _launch(self, name: str, wait: bool) -> None:
        target, args = self._targets[name]
        self._stopped.discard(name)
        ready = self._ctx.Event()
        proc = self._ctx.Process(target=run_child, name=name, args=(
            target, args, ready, logging.getLogger().getEffectiveLevel()))
        proc.start()
        self._procs[name] = proc
        self._starting.append((proc, ready))
        if wait:
            self.wait_ready()

    def wait_ready(self, timeout: float = READY_TIMEOUT) -> None:
        """Wait until every child started so far is ready; RuntimeError names the first
        that ended (or was not ready within ``timeout`` seconds) instead."""
        deadline = time.monotonic() + timeout
        while self._starting:
            proc, ready = self._starting[0]
            if ready.wait(min(READY_CHECK, max(0.0, deadline - time.monotonic()))):
                self._starting.pop(0)
                continue
            for other, _ in self._starting:
                if not other.is_alive():
                    raise RuntimeError(f"{other.name} did not start (exit code "
                                       f"{other.exitcode})")
            if time.monotonic() >= deadline:
                raise RuntimeError(f"{proc.name} was not ready within {timeout:g} s")

    def alive(self, name: str) -> bool:
        """Whether child ``name`` is still running."""
        return self._procs[name].is_alive()

    def pid(self, name: str) -> int:
        """Child ``name``'s process id (the testbed shapes what a process sends)."""
        pid = self._procs[name].pid
        if pid is None:
            raise ValueError(f"child {name!r} has not started")
        return pid

    def exit_code(self, name: str) -> int | None:
        """Child ``name``'s exit code (negative: the signal that ended it); None while
        it runs. For reports that must say which process failed."""
        return self._procs[name].exitcode

    def join(self, timeout: float) -> bool:
        """Wait up to ``timeout`` seconds in all for every child to end; True if they did."""
        deadline = time.monotonic() + timeout
        for proc in self._procs.values():
            proc.join(max(0.0, deadline - time.monotonic()))
        return not any(proc.is_alive() for proc in self._procs.values())

    def __enter__(self) -> Children:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop(list(self._procs))

    def stop(self, names: Sequence[str]) -> None:
        """Stop these children (those not stopped yet) now, before the others: senders
        before their receiver, which would otherwise see them cut off as by a fault."""
        procs = [self._procs[name] for name in names if name not in self._stopped]
        self._stopped.update(names)
        for proc in procs:
            if proc.is_alive():
                proc.terminate()  # SIGTERM: the child's request to stop
        for proc in reversed(procs):
            proc.join(STOP_TIMEOUT)
            if proc.is_alive():
                log.warning("%s did not stop: killing it", proc.name)
                proc.kill()
                proc.join()
            elif proc.exitcode != 0:
                log.warning("%s exited with code %s", proc.name, proc.exitcode)


class StatsCollector:
    """Keeps the latest stats JSON of every follower and of the leader, and every sample."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys, start: float) -> None:
        self._keys = keys
        self._start = start
        self._lock = threading.Lock()
        self.latest: dict[str, dict[str, Any]] = {}
        self.leader: dict[str, Any] = {}
        self.rows: list[dict[str, Any]] = []
        self.rates = PollRates()
        self._subscriber = session.declare_subscriber(keys.all_stats, self._on_stats)

    def _on_stats(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        try:
            record = json.loads(sample.payload.to_bytes())
        except ValueError:
            log.warning("stats on %s are not JSON", key)
            return
        now = time.time()
        with self._lock:
            if key == self._keys.leader_stats:
                self.leader = record
                return
            follower = self._keys.follower_of(key, "stats")
            if follower is None or not isinstance(record, dict):
                return
            self.latest[follower] = record
            self.rows.append({"time_s": round(now - self._start, 3), **record})
            self.rates.observe(follower, float(record.get("polls", 0)), now)

    def table(self, title: str) -> list[str]:
        with self._lock:
            leader = self.leader
            header = (f"{title} | leader {float(leader.get('polls_per_s', 0.0)):.0f} polls/s, "
                      f"mean AoI {float(leader.get('mean_aoi_s', 0.0)) * 1e3:.2f} ms")
            return format_table(list(self.latest.values()), dict(self.rates.rates), header)

    def close(self) -> None:
        undeclare(self._subscriber)


def _run_dir(out: str) -> Path:
    base = Path(out) / time.strftime("%Y%m%d-%H%M%S")
    path, n = base, 1
    while path.exists():
        n += 1
        path = base.with_name(f"{base.name}-{n}")
    path.mkdir(parents=True)
    return path


def run_demo(options: DemoOptions, stream: TextIO = sys.stdout) -> Path:
    """Run the demo; returns the run directory. Ctrl-C (or SIGTERM) ends it early."""
    run_dir = _run_dir(options.out)
    port = free_tcp_port()
    node_spec = SessionSpec.loopback("peer", connect_ports=[port])
    keys = SwarmKeys(options.swarm)
    record = run_dir / "deliveries.csv"
    table = LiveTable(stream)
    title = f"WiSwarm demo: {options.followers} followers, {options.policy}"
    collector: StatsCollector | None = None
    interrupted = False
    try:
        with sigterm_as_ctrl_c(), Children(multiprocessing.get_context("spawn")) as children:
            stream.write(f"starting a router on 127.0.0.1:{port}, a leader and "
                         f"{options.followers} followers...\n")
            stream.flush()
            children.start("router", run_router, SessionSpec.loopback("router", port))
            for i in range(1, options.followers + 1):
                follower = FollowerOptions(options.swarm, f"uav{i}", FollowerConfig(),
                                           options.frame_bytes, options.frame_rate)
                children.start(f"follower uav{i}", run_follower, node_spec, follower,
                               wait=False)
            children.wait_ready()
            leader = LeaderOptions(options.swarm, LeaderConfig(policy=options.policy),
                                   record=str(record))
            with node_spec.open() as session:
                collector = StatsCollector(session, keys, time.time())
                children.start("leader", run_leader, node_spec, leader)
                start = time.monotonic()
                while (elapsed := time.monotonic() - start) < options.duration:
                    table.show(collector.table(f"{title}, {elapsed:4.1f}/{options.duration:g} s"))
                    time.sleep(min(REFRESH, max(0.0, options.duration - elapsed)))
                collector.close()
    except KeyboardInterrupt:
        interrupted = True
        stream.write("\ninterrupted: every process stopped\n")
    _write_outputs(run_dir, collector, record, title, stream)
    if interrupted:
        raise KeyboardInterrupt
    return run_dir


def _write_outputs(run_dir: Path, collector: StatsCollector | None, record: Path, title: str,
                   stream: TextIO) -> None:
    if collector is not None:
        stream.write("\n".join(["", "summary", *collector.table(title)]) + "\n")
        write_stats_csv(run_dir / "stats.csv", collector.rows)
        stream.write(f"stats:      {run_dir / 'stats.csv'} ({len(collector.rows)} rows)\n")
    if record.exists():
        deliveries = read_deliveries(record)
        if deliveries:
            times = [d for rows in deliveries.values() for d, _ in rows]
            plot_aoi(run_dir / "aoi.png", deliveries, min(times), max(times))
            stream.write(f"AoI plot:   {run_dir / 'aoi.png'}\n")
        stream.write(f"deliveries: {record} ({sum(map(len, deliveries.values()))})\n")
    stream.flush()
