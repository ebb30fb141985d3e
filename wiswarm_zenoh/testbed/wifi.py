"""The WiFi medium (``--medium wifi``): one namespace per node on one simulated 2.4 GHz
802.11 channel, node 0 the access point the leader side sits behind, nodes 1..N stations,
one per follower, each contending for the air.

Infrastructure mode, not ad hoc: the paper's UAVs reach a ground station through its
access point, and every station's frames then go to one receiver, as a swarm's uplink
does. Each namespace holds a tap (``wsw28-wifi``) carrying its ns-3 device's own MAC
address; the ns-3 scenario (``ns3/wifi_medium.cc``, built on first use) opens the taps
and runs in real time under a hard limit on lag, writing its counters (per node: frames
through the tap, MAC acks, failed transmissions, drops, airtime; the largest lag) as JSON
lines to a stats file. A lag beyond the limit ends the scenario: ``check`` then raises.
A station's data rate can be lowered at run time (``set_station_rate``: a command on the
scenario's stdin, answered on its stdout).

Its records, and the removal of media whose owner died: ``wifi_records``.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import logging
import os
import re
import select
import subprocess
from dataclasses import asdict, replace
from pathlib import Path
from types import TracebackType
from typing import IO, Any

from wiswarm_zenoh.testbed.ns3_build import scenario_binary
from wiswarm_zenoh.testbed.ownership import (
    locked,
    namespace_exists,
    process_start,
)
from wiswarm_zenoh.testbed.spec import MTU, check_available
from wiswarm_zenoh.testbed.tc import run
from wiswarm_zenoh.testbed.wifi_records import (
    NS_PREFIX,
    RECORDS,
    STOP_TIMEOUT,
    cleanup_locked,
    list_media,
    load_record,
    ns_name,
    record_paths,
    remove_locked,
    save_record,
)
from wiswarm_zenoh.testbed.wifi_spec import MediumFailed, MediumStats, WifiSpec

log = logging.getLogger(__name__)

TAP = "wsw28-wifi"
SUBNETS = range(1, 255)  # medium k: AP 10.203.k.1, station i 10.203.k.(i + 1)
DEFAULT_SPEC = WifiSpec()
_counter = itertools.count()


class WifiMedium:
    """One simulated WiFi channel with its namespaces; a context manager that builds it
    and removes it. ``name`` chooses the run id, as for ``Channel``."""

    run_id: str
    subnet: int

    def __init__(self, spec: WifiSpec = DEFAULT_SPEC, name: str | None = None) -> None:
        self.spec = spec
        self.persistent = False
        self.owner_pid = os.getpid()
        self._name = name
        self._built = False
        self._scenario: subprocess.Popen[str] | None = None

    def __enter__(self) -> WifiMedium:
        return self.build()

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    @property
    def leader_ns(self) -> str:
        """The access point's namespace: router and leader (or receiver) live there."""
        return ns_name(self.run_id, 0)

    @property
    def leader_addr(self) -> str:
        return self.address(0)

    @property
    def station_namespaces(self) -> list[str]:
        """One namespace per station, follower i (0-based) in the (i + 1)-th."""
        return [ns_name(self.run_id, i) for i in range(1, self.spec.stations + 1)]

    def address(self, node: int) -> str:
        return f"10.203.{self.subnet}.{node + 1}"

    def build(self, *, persistent: bool = False) -> WifiMedium:
        """Namespaces and taps, then the scenario, in real time once this returns."""
        if self._built:
            return self
        check_available()
        binary = scenario_binary()
        with locked(RECORDS):
            cleanup_locked()
            self.run_id = self._name or self._fresh_id()
            if self.run_id in list_media() or record_paths(self.run_id)[0].exists():
                raise ValueError(f"a WiFi medium named {self.run_id!r} exists already")
            used = {int(r["subnet"]) for r in map(load_record, list_media()) if r is not None}
            subnet = next((k for k in SUBNETS if k not in used), None)
            if subnet is None:
                raise RuntimeError("every WiFi medium subnet is in use: remove media with "
                                   "`wiswarm testbed down`")
            self.subnet, self.persistent = subnet, persistent
            owner = 0 if persistent else os.getpid()
            self._record: dict[str, Any] = {"run_id": self.run_id, "owner_pid": owner,
                            "owner_start": process_start(owner) if owner else 0,
                            "subnet": subnet, "spec": asdict(self.spec),
                            "scenario_pid": 0, "scenario_start": None}
            save_record(self._record)
            try:
                self._create()
                self._start(binary)
            except BaseException:
                remove_locked(self.run_id, self._record)
                raise
        self._built = True
        log.info("WiFi medium %s up: %d stations, %s, hard lag limit %g ms", self.run_id,
                 self.spec.stations, self.spec.standard, self.spec.hard_limit_ms)
        return self

    @staticmethod
    def _fresh_id() -> str:
        taken = set(list_media())
        while True:
            run_id = f"{os.getpid():x}-{next(_counter)}"
            if run_id not in taken and not record_paths(run_id)[0].exists():
                return run_id

    def _create(self) -> None:
        for node in range(self.spec.stations + 1):
            ns = ns_name(self.run_id, node)
            run("ip", "netns", "add", ns)
            run("ip", "-n", ns, "tuntap", "add", "dev", TAP, "mode", "tap")
            # One MTU-sized packet per skb (as on the tbf channel), no IPv6 chatter.
            run("ip", "-n", ns, "link", "set", "dev", TAP, "mtu", str(MTU), "gso_max_size",
                str(MTU), "gso_max_segs", "1", "addrgenmode", "none")
            run("ip", "-n", ns, "addr", "add", f"{self.address(node)}/24", "dev", TAP)
            run("ip", "-n", ns, "link", "set", "dev", "lo", "up")

    def _start(self, binary: Path) -> None:
        _, stats, errors = record_paths(self.run_id)
        namespaces = [ns_name(self.run_id, node) for node in range(self.spec.stations + 1)]
        argv = [str(binary), f"--stations={self.spec.stations}",
                f"--standard={self.spec.standard}", f"--namespaces={','.join(namespaces)}",
                f"--tap={TAP}", f"--hardLimitMs={self.spec.hard_limit_ms:g}",
                f"--statsFile={stats}"]
        if self.spec.data_mode:
            argv.append(f"--dataMode={self.spec.data_mode}")
        with errors.open("w") as stderr:
            scenario = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        stderr=stderr, text=True, start_new_session=True)
        self._scenario = scenario
        self._record.update(scenario_pid=scenario.pid,
                            scenario_start=process_start(scenario.pid))
        save_record(self._record)
        assert scenario.stdin is not None and scenario.stdout is not None
        addresses = self._expect(scenario.stdout, "addresses")
        for ns, mac in zip(namespaces, addresses["macs"], strict=True):
            run("ip", "-n", ns, "link", "set", "dev", TAP, "address", str(mac))
            run("ip", "-n", ns, "link", "set", "dev", TAP, "up")
        self._command("go")  # stdin stays open for commands (set_station_rate)
        self._expect(scenario.stdout, "ready")

    def _command(self, line: str) -> None:
        assert self._scenario is not None and self._scenario.stdin is not None
        self._scenario.stdin.write(f"{line}\n")
        self._scenario.stdin.flush()

    def set_station_rate(self, station: int, data_mode: str) -> None:
        """Station ``station``'s (1 .. stations, as in ``address``) data rate from now on:
        a robot flying away, its rate adaptation stepping down. Its frames to the access
        point go at ``data_mode`` (an ns-3 WifiMode of the medium's standard, as in
        WifiSpec); the access point's to it and control frames keep theirs. Returns once
        the scenario applied it. ValueError for a station or mode the medium lacks;
        RuntimeError on a medium another process built (commands go to its scenario's
        stdin); MediumFailed if the scenario ended or does not answer."""
        if not (isinstance(station, int) and 1 <= station <= self.spec.stations):
            raise ValueError(f"station must be in [1, {self.spec.stations}] on WiFi medium "
                             f"{self.run_id}, got {station!r}")
        replace(self.spec, data_mode=data_mode)  # the mode's own check, naming it
        scenario = self._scenario
        if scenario is None or scenario.stdout is None:
            raise RuntimeError(f"only the process that built WiFi medium {self.run_id} can "
                               "change its rates")
        self.check()
        try:
            self._command(f"rate {station} {data_mode}")
        except BrokenPipeError:
            self.check()  # it ended meanwhile: says how
            raise
        if not select.select([scenario.stdout], [], [], STOP_TIMEOUT)[0]:
            self.check()
            raise MediumFailed(f"WiFi medium {self.run_id}: the ns-3 scenario did not answer "
                               f"`rate` in {STOP_TIMEOUT:g} s")
        answer = json.loads(scenario.stdout.readline() or "{}")
        if answer.get("event") != "rate":
            self.check()
            raise ValueError(f"WiFi medium {self.run_id}: "
                             f"{answer.get('message', 'no answer to `rate`')}")
        log.info("WiFi medium %s: station %d's data rate now %s (t=%.3f s)", self.run_id,
                 station, data_mode, answer["t"])

    def _expect(self, stream: IO[str], event: str) -> dict[str, Any]:
        line = stream.readline()
        try:
            message: dict[str, Any] = json.loads(line)
        except ValueError:
            message = {}
        if message.get("event") != event:
            raise MediumFailed(f"the ns-3 scenario did not start: {self._stderr_tail()}")
        return message

    def _stderr_tail(self) -> str:
        with contextlib.suppress(OSError):
            text = record_paths(self.run_id)[2].read_text().strip()
            return text[-500:] or "no message"
        return "no message"

    @property
    def scenario_process(self) -> tuple[int, int | None]:
        """The ns-3 scenario's pid and start time (clock ticks), as recorded."""
        record = load_record(self.run_id) or self._record
        return int(record["scenario_pid"]), record["scenario_start"]

    def stats(self) -> MediumStats:
        """The scenario's last counters (cumulative since it started)."""
        last = None
        with contextlib.suppress(OSError), record_paths(self.run_id)[1].open() as lines:
            for line in lines:
                last = line
        if last is None:
            return MediumStats(0.0, 0.0)
        data = json.loads(last)
        return MediumStats(float(data["t"]), float(data["max_lag_ms"]), data["nodes"],
                           str(data["event"]))

    def check(self) -> None:
        """MediumFailed if the scenario has ended (lag beyond the hard limit, a crash)."""
        record = load_record(self.run_id) or {}
        pid = int(record.get("scenario_pid", 0))
        if self._scenario is not None and self._scenario.poll() is None:
            return
        if self._scenario is None and pid > 0 \
                and process_start(pid) == record.get("scenario_start"):
            return
        stats, stderr = self.stats(), self._stderr_tail()
        jitter = re.search(r"Hard real-time limit exceeded \(jitter = (\d+)\)", stderr)
        if stats.event == "lag-exceeded" or jitter:  # our watch, or ns-3's own HardLimit
            lag = max(stats.max_lag_ms, int(jitter.group(1)) / 1e6 if jitter else 0.0)
            raise MediumFailed(f"WiFi medium {self.run_id}: the simulation fell more than "
                               f"{self.spec.hard_limit_ms:g} ms behind real time (lag "
                               f"{lag:.3f} ms): this machine cannot hold "
                               f"{self.spec.stations} stations at this load")
        why = ("it was stopped (SIGTERM: `wiswarm testbed down`?)" if stats.event == "end"
               else stderr)
        raise MediumFailed(f"WiFi medium {self.run_id}: the ns-3 scenario ended: {why}")

    def close(self) -> None:
        """Stop the scenario, remove namespaces, taps and record; safe to repeat."""
        if not self._built:
            return
        if self._scenario is not None:
            with self._scenario as scenario:  # its pipes closed on leaving
                if scenario.poll() is None:
                    scenario.terminate()
                    try:
                        scenario.wait(STOP_TIMEOUT)
                    except subprocess.TimeoutExpired:
                        scenario.kill()
        with locked(RECORDS):
            remove_locked(self.run_id, load_record(self.run_id))
        self._built = False
        log.info("WiFi medium %s removed", self.run_id)

    def describe(self) -> str:
        owner = ("persistent (until `wiswarm testbed down`)" if self.persistent
                 else f"owned by pid {self.owner_pid}")
        stats = self.stats()
        return "\n".join((
            f"WiFi medium {self.run_id}, {owner}",
            f"  ns-3 {self.spec.standard} at 2.4 GHz, data rate "
            f"{self.spec.data_mode or 'the standard default'}, {self.spec.stations} stations "
            "and an access point, in real time",
            f"  largest lag behind real time {stats.max_lag_ms:.2f} ms "
            f"(hard limit {self.spec.hard_limit_ms:g} ms) at t={stats.t:.0f} s",
            f"  leader side: router + leader in {self.leader_ns} at {self.leader_addr}",
            f"  stations: followers in {NS_PREFIX}{self.run_id}-s1 .. "
            f"-s{self.spec.stations} at {self.address(1)} .. "
            f"{self.address(self.spec.stations)}",
        ))

    @classmethod
    def attach(cls, run_id: str) -> WifiMedium:
        """The present medium ``run_id`` (made by any process); LookupError if none."""
        record = load_record(run_id)
        if record is None or not namespace_exists(ns_name(run_id, 0)):
            raise LookupError(f"no WiFi medium {run_id!r}")
        medium = cls(WifiSpec(**record["spec"]))
        medium.run_id, medium.subnet = run_id, int(record["subnet"])
        medium.persistent = int(record["owner_pid"]) == 0
        medium.owner_pid = int(record["owner_pid"])
        medium._record = record
        medium._built = True
        return medium
