"""Faults injected into a swarm of real ``wiswarm`` processes on loopback.

A router, a leader recording every delivery (``--record``) and followers, each its own
process started as a user would start it, all clients of the router; standby leaders
too, each recording what it delivers once it takes over. A follower can be
stopped (SIGSTOP) and continued, or killed; the router killed and started again on the
same port. What the others kept getting is read from the leader's record afterwards;
what each process said, from its output.
"""

from __future__ import annotations

import csv
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

READY = 60.0  # seconds a process may take to come up on a busy machine
ANSI = re.compile(r"\x1b\[[0-9;]*m")


@dataclass(frozen=True)
class Delivery:
    follower: str
    update_seq: int
    delivered_at: float  # leader clock (time.time())


class Output:
    """What a process writes on its stdout, kept line by line as it comes (read by a
    thread: the process must never block on a full pipe), colour codes removed."""

    def __init__(self, name: str, popen: subprocess.Popen[str]) -> None:
        self.name = name
        self.popen = popen
        self.lines: list[str] = []
        self.times: list[float] = []  # when each line came (time.monotonic)
        self._cond = threading.Condition()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            with self._cond:
                self.lines.append(ANSI.sub("", line.rstrip("\n")))
                self.times.append(time.monotonic())
                self._cond.notify_all()
        with self._cond:  # the end of the output: nothing more will come
            self._cond.notify_all()

    def _find(self, texts: Sequence[str]) -> str | None:
        return next((line for line in self.lines if all(t in line for t in texts)), None)

    def wait_for(self, *texts: str, timeout: float = READY) -> str:
        """The first line holding all of ``texts`` (it must come)."""
        with self._cond:
            if not self._cond.wait_for(lambda: self._find(texts) is not None, timeout):
                raise RuntimeError(f"{self.name} never said {texts!r}: {self.lines[-5:]}")
            return str(self._find(texts))

    def when(self, text: str, timeout: float) -> float | None:
        """When the first line holding ``text`` came (``time.monotonic``); None if none
        came within ``timeout`` or before the output ended."""
        def at() -> float | None:
            return next((t for line, t in zip(self.lines, self.times, strict=True)
                         if text in line), None)

        with self._cond:
            self._cond.wait_for(lambda: at() is not None or not self._reader.is_alive(),
                                max(0.0, timeout))
            return at()

    def read_to_end(self, timeout: float) -> None:
        """Wait until every line the process wrote is in ``lines`` (its output closed)."""
        self._reader.join(timeout)

    def said(self, text: str) -> bool:
        with self._cond:
            return self._find((text,)) is not None


class Process(Output):
    """A ``wiswarm`` command started as a user would start it, and its output."""

    def __init__(self, name: str, argv: Sequence[str], env: dict[str, str] | None = None,
                 cwd: Path | None = None) -> None:
        super().__init__(name, subprocess.Popen(
            [sys.executable, "-m", "wiswarm_zenoh.cli.main", *argv], env=env, cwd=cwd,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True))

    def signal(self, signum: int) -> None:
        self.popen.send_signal(signum)

    def stop(self) -> None:
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGCONT)
            self.popen.terminate()
            try:
                self.popen.wait(10)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait(10)


class FaultySwarm:
    """Router, leader, ``standbys`` (leaders started after it, in that order) and
    ``followers`` as processes; use as a context manager."""

    def __init__(self, directory: Path, followers: Sequence[str], frame_bytes: int = 50176,
                 fragment_size: int | None = None, standbys: Sequence[str] = ()) -> None:
        self.port = free_tcp_port()
        self._directory = directory
        self.record = directory / "deliveries.csv"
        self._standby_names = list(standbys)
        self.standbys: dict[str, Process] = {}
        self._env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self._followers = list(followers)
        self._frame_bytes = frame_bytes
        self._fragment_size = fragment_size
        self.router: Process | None = None
        self.leader: Process | None = None
        self.followers: dict[str, Process] = {}

    def _node_flags(self) -> list[str]:
        return ["-m", "client", "-e", f"tcp/127.0.0.1:{self.port}",
                "--cfg", "transport/shared_memory/enabled:false"]

    def start_router(self) -> float:
        """A router on the swarm's port; returns when it listens."""
        self.router = Process("router", ["router", "-l", f"tcp/127.0.0.1:{self.port}",
                                         "--no-multicast-scouting"], self._env)
        self.router.wait_for("listening")
        return time.time()

    def __enter__(self) -> FaultySwarm:
        try:
            self.start_router()
            for name in self._followers:
                extra = [] if self._fragment_size is None else \
                    ["--fragment-size", str(self._fragment_size)]
                self.followers[name] = Process(name, [
                    "follower", "--id", name, "--frame-bytes", str(self._frame_bytes),
                    *extra, *self._node_flags()], self._env)
            # -v: the leader's INFO lines too (a follower answering again is normal life)
            self.leader = Process("leader", ["-v", "leader", "--record", str(self.record),
                                             "--name", "leader", *self._node_flags()],
                                  self._env)
            for process in (*self.followers.values(), self.leader):
                process.wait_for("(Ctrl-C to stop)")
            for name in self._standby_names:  # one by one: each younger than the last
                self.standbys[name] = Process(name, [
                    "-v", "leader", "--record", str(self._record_of(name)), "--name", name,
                    *self._node_flags()], self._env)
                self.standbys[name].wait_for(f"leader {name} stands by")
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _record_of(self, leader: str) -> Path:
        return self._directory / f"deliveries-{leader}.csv"

    def close(self) -> None:
        for process in (self.leader, *self.standbys.values(), *self.followers.values(),
                        self.router):
            if process is not None:
                process.stop()

    def kill_router(self) -> float:
        assert self.router is not None
        self.router.signal(signal.SIGKILL)
        self.router.popen.wait(10)
        return time.time()

    def deliveries(self, leader: str | None = None) -> list[Delivery]:
        """Every delivery the leader (or the standby named ``leader``) recorded so far
        (records are line-buffered)."""
        record = self.record if leader is None else self._record_of(leader)
        if not record.exists():
            return []
        with record.open(newline="") as file:
            return [Delivery(row["follower"], int(row["update_seq"]),
                             float(row["delivered_at"])) for row in csv.DictReader(file)
                    if row.get("delivered_at")]

    def wait_deliveries(self, followers: Sequence[str], count: int, after: float = 0.0,
                        timeout: float = READY, leader: str | None = None) -> None:
        """Until each of ``followers`` has ``count`` deliveries recorded after ``after``
        (by the first leader, or the standby named ``leader``)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            done = [d for d in self.deliveries(leader) if d.delivered_at > after]
            if all(sum(d.follower == f for d in done) >= count for f in followers):
                return
            time.sleep(0.1)  # a file, not an event: re-read it until it holds enough
        raise RuntimeError(f"fewer than {count} deliveries each from {followers}")


def rate(deliveries: Sequence[Delivery], followers: Sequence[str], start: float,
         end: float) -> float:
    """Deliveries per second from ``followers`` between ``start`` and ``end``."""
    count = sum(1 for d in deliveries if d.follower in followers and start <= d.delivered_at
                < end)
    return count / (end - start)


def first_after(deliveries: Sequence[Delivery], moment: float) -> float | None:
    """The first delivery time after ``moment``."""
    return min((d.delivered_at for d in deliveries if d.delivered_at > moment), default=None)
