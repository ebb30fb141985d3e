"""The processes of ``bench_soak.py``'s swarm: each a ``wiswarm`` command in a ``spawn``
child, started, stopped by a signal, reaped and judged (ended as told, no traceback);
and what ``/proc`` says of them (memory, fds, threads)."""

from __future__ import annotations

import multiprocessing
import os
import signal
import socket
import time
from multiprocessing.context import SpawnProcess
from pathlib import Path

from bench_shm import zenoh_segments

SWARM = "soak"


def cli_node(argv: list[str], log_path: str) -> None:
    """A ``spawn`` child running ``wiswarm *argv``: its stdout (the leader's table) is
    dropped, its stderr (warnings, a traceback) kept in ``log_path``."""
    from wiswarm_zenoh.cli.main import main
    from wiswarm_zenoh.programs.process_exit import exit_without_finalizing

    with open(os.devnull, "w") as devnull, open(log_path, "a") as log:
        os.dup2(devnull.fileno(), 1)
        os.dup2(log.fileno(), 2)
    exit_without_finalizing(main(argv))


def proc_status(pid: int) -> dict[str, int]:
    """Resident memory and its shared-memory part (bytes), threads, open fds."""
    values = {}
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            key, _, rest = line.partition(":")
            if key in ("VmRSS", "RssShmem"):
                values[key] = int(rest.split()[0]) * 1024
            elif key == "Threads":
                values[key] = int(rest)
    values["fds"] = len(os.listdir(f"/proc/{pid}/fd"))
    return values


class Swarm:
    """The run's processes by name, each a ``wiswarm`` command in a ``spawn`` child."""

    def __init__(self, port: int, out: Path, shared_memory: bool) -> None:
        self._ctx = multiprocessing.get_context("spawn")
        self.endpoint = f"tcp/127.0.0.1:{port}"
        self._out = out
        self._flags = ["--no-multicast-scouting", *(["--shared-memory"] if shared_memory
                                                    else [])]
        self.procs: dict[str, SpawnProcess] = {}
        self.ended: dict[str, int | None] = {}  # name: exit code
        self.expected: dict[str, int] = {}  # name: the exit code its stop should give
        self.segments: set[str] = set()  # every Zenoh segment file one of them mapped

    def start(self, name: str, command: list[str]) -> None:
        argv = [*command, *self._flags]
        if command[0] == "router":
            argv += ["-l", self.endpoint]
        else:
            argv += ["--swarm", SWARM, "-m", "client", "-e", self.endpoint]
        proc = self._ctx.Process(target=cli_node, name=name,
                                 args=(argv, str(self._out / f"{name}.log")))
        proc.start()
        self.procs[name] = proc

    def pid(self, name: str) -> int:
        pid = self.procs[name].pid
        assert pid is not None
        return pid

    def note_segments(self) -> None:
        for proc in self.procs.values():
            if proc.pid is not None and proc.is_alive():
                self.segments |= zenoh_segments(proc.pid)

    def end(self, name: str, how: signal.Signals) -> None:
        """Stop ``name`` by ``how`` (SIGTERM: cleanly, exit 0; SIGKILL: -9); reaped later.
        One that has ended already (multiprocessing reaps ended children whenever it
        starts one) is left as it is: its pid may be another process's by now."""
        self.segments |= zenoh_segments(self.pid(name))
        self.expected.setdefault(name, 0 if how == signal.SIGTERM else -how)
        if self.procs[name].is_alive():
            os.kill(self.pid(name), how)

    def reap(self, wait: float = 0.0) -> None:
        """Join what has ended (waiting up to ``wait`` s for each one told to end)."""
        for name in list(self.procs):
            proc = self.procs[name]
            proc.join(wait if name in self.expected else 0.0)
            if not proc.is_alive():
                self.ended[name] = proc.exitcode
                del self.procs[name]

    def stop_all(self) -> None:
        self.note_segments()
        for name in list(self.procs):
            self.end(name, signal.SIGTERM)
        self.reap(15.0)
        for name, proc in list(self.procs.items()):
            proc.kill()
            proc.join(5.0)
            self.ended[name] = proc.exitcode

    def _stopped_starting(self, name: str, code: int | None) -> bool:
        """Told SIGTERM while still starting (the spawn child importing, before the
        command installed its handler), a process ends by the signal itself: as told,
        not a crash. A running node's clean stop is tests/transport/test_cli.py's."""
        return self.expected.get(name) == 0 and code == -signal.SIGTERM

    def surprises(self) -> list[str]:
        """Processes that ended other than told (a crash), and tracebacks in the logs."""
        found = [f"{name} ended with {code}" for name, code in self.ended.items()
                 if code != self.expected.get(name) and not self._stopped_starting(name, code)]
        found += [f"{log.name} has a traceback" for log in sorted(self._out.glob("*.log"))
                  if "Traceback" in log.read_text(errors="replace")]
        return found


def wait_for_port(port: int, timeout: float) -> None:
    """Until the router accepts connections."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
            return
        except OSError:
            if time.monotonic() > deadline:
                raise RuntimeError("the router did not listen") from None
            time.sleep(0.05)


def sample(swarm: Swarm, leader: str, steady: list[str]) -> dict[str, dict[str, int]]:
    """The router's and the leader's figures, and the largest of each over the steady
    followers."""
    nodes = {"router": proc_status(swarm.pid("router")), "leader": proc_status(swarm.pid(leader))}
    followers = [proc_status(swarm.pid(name)) for name in steady]
    nodes["follower"] = {key: max(f[key] for f in followers) for key in followers[0]}
    return nodes
