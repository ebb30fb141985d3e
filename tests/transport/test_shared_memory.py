"""Zenoh's shared memory is off unless a node asks for it (``--shared-memory``); where it
is on, nothing of the node's stays in /dev/shm once every process has ended, however
each ended (``shm_sweep``)."""

from __future__ import annotations

import dataclasses
import fcntl
import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time
from multiprocessing.context import SpawnProcess
from pathlib import Path

import pytest

from wiswarm_zenoh import DeliveryRecord, Observer
from wiswarm_zenoh.cli import nodes
from wiswarm_zenoh.cli.main import build_parser
from wiswarm_zenoh.programs.runners import (
    FollowerOptions,
    LeaderOptions,
    run_child,
    run_follower,
    run_leader,
    run_router,
)
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.shm_sweep import sweep, watch
from wiswarm_zenoh.transport.zenoh_config import SHARED_MEMORY, free_tcp_port

from .helpers import WAIT

SWARM = "shm"
FILE_SAYS_ON = '{mode: "client", transport: {shared_memory: {enabled: true}}}'


def _enabled(spec: SessionSpec) -> str:
    return spec.config().get_json(SHARED_MEMORY)


def test_off_unless_asked_for(tmp_path: Path) -> None:
    spec = SessionSpec.loopback("peer")
    assert _enabled(spec) == "false"
    assert _enabled(dataclasses.replace(spec, shared_memory=True)) == "true"
    assert _enabled(dataclasses.replace(spec, cfg=(f"{SHARED_MEMORY}:true",))) == "true"
    file = tmp_path / "node.json5"
    file.write_text(FILE_SAYS_ON)  # the flag decides, whatever a file says
    assert _enabled(SessionSpec(config_file=str(file))) == "false"
    assert _enabled(SessionSpec(config_file=str(file), shared_memory=True)) == "true"


@pytest.mark.parametrize("command", [["router"], ["leader"], ["follower", "--id", "uav1"]])
def test_every_node_takes_the_flag(command: list[str]) -> None:
    parser = build_parser((nodes.register,))
    assert not SessionSpec.from_args(parser.parse_args(command), "peer").shared_memory
    args = parser.parse_args([*command, "--shared-memory"])
    assert _enabled(SessionSpec.from_args(args, "peer")) == "true"


def test_the_sweep_removes_only_what_nobody_holds(tmp_path: Path) -> None:
    held, orphan, other = tmp_path / "1.zenoh", tmp_path / "2.zenoh", tmp_path / "x.zenoh"
    for path in (held, orphan, other):
        path.write_bytes(b"\0" * 64)
    with open(held, "rb") as holder:  # as a process that maps a segment holds it
        fcntl.flock(holder, fcntl.LOCK_SH)
        assert sweep(tmp_path) == ["2.zenoh"]
    assert held.exists() and not orphan.exists() and other.exists()


HOLDER = ("import fcntl, sys, time; f = open(sys.argv[1], 'rb'); fcntl.flock(f, fcntl.LOCK_SH); "
          "print('held', flush=True); time.sleep(60)")


def _gone(paths: list[Path]) -> list[Path]:
    """``paths`` that still exist once they are gone or WAIT has passed (a file going
    is no event one can wait on)."""
    deadline = time.monotonic() + WAIT
    while any(path.exists() for path in paths) and time.monotonic() < deadline:
        time.sleep(0.05)
    return [path for path in paths if path.exists()]


def test_a_sweeper_sweeps_once_its_process_has_ended_however(tmp_path: Path) -> None:
    segment = tmp_path / "7.zenoh"
    segment.write_bytes(b"\0" * 64)
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(segment)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        watch(holder.pid, tmp_path)
        assert segment.exists()
    finally:
        holder.kill()
        holder.wait()
    assert _gone([segment]) == []


def _segments(pid: int) -> set[str]:
    with open(f"/proc/{pid}/maps") as maps:
        return {w for line in maps for w in line.split() if w.endswith(".zenoh")}


@pytest.mark.parametrize("shared_memory", [True, False])
def test_nothing_stays_in_dev_shm(shared_memory: bool) -> None:
    """A router, a leader and a follower (50 kB frames) on one host; the follower killed,
    the others stopped: with shared memory on, they mapped segments and none is left;
    off, they mapped none."""
    port = free_tcp_port()
    router = dataclasses.replace(SessionSpec.loopback("router", port),
                                 shared_memory=shared_memory)
    node = dataclasses.replace(SessionSpec.loopback("client", connect_ports=[port]),
                               shared_memory=shared_memory)
    ctx = multiprocessing.get_context("spawn")
    procs: list[SpawnProcess] = []
    delivered = threading.Event()

    def on_record(observation: object) -> None:
        if isinstance(observation, DeliveryRecord) and observation.outcome == "delivered":
            delivered.set()

    try:
        for target, args in [(run_router, (router,)),
                             (run_follower, (node, FollowerOptions(SWARM, "uav1"))),
                             (run_leader, (node, LeaderOptions(SWARM)))]:
            ready = ctx.Event()
            procs.append(ctx.Process(target=run_child, args=(target, args, ready)))
            procs[-1].start()
            assert ready.wait(WAIT)
        with SessionSpec.loopback("client", connect_ports=[port]).open() as session, \
                Observer(session, SWARM, on_record):
            assert delivered.wait(WAIT)
        pids = [proc.pid for proc in procs if proc.pid is not None]
        mapped = set().union(*(_segments(pid) for pid in pids))
        os.kill(pids[1], signal.SIGKILL)
        for proc in (procs[2], procs[0]):
            proc.terminate()
        for proc in procs:
            proc.join(WAIT)
            assert proc.exitcode in (0, -signal.SIGKILL)
    finally:
        for proc in procs:
            proc.kill()
    assert bool(mapped) == shared_memory
    assert _gone([Path(path) for path in mapped]) == []  # each process's sweeper swept
