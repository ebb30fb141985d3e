"""Runs over a real emulated channel: frames cross the shaped link, both WiSwarm and push
deliver, faults are survived and reported, an interrupted study keeps what it measured
and leaves no channel behind."""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from wiswarm_zenoh.experiments.testbed_study import measure_fresh
from wiswarm_zenoh.programs.demo import Children
from wiswarm_zenoh.programs.frames import FRAME_BYTES
from wiswarm_zenoh.programs.runners import ReadySignal, StopSignal
from wiswarm_zenoh.testbed import Channel, ChannelSpec, list_channels
from wiswarm_zenoh.testbed import run as run_module
from wiswarm_zenoh.testbed.nodes import Placement
from wiswarm_zenoh.testbed.run import Group, RunOutcome, RunSpec, measure, read_record

from .channel_helpers import left_behind

pytestmark = pytest.mark.testbed


def _measure_across(channel: Channel, spec: RunSpec, workdir: Path) -> RunOutcome:
    """``measure``, with the uplink's counters read before and after it: every follower
    delivered, every frame delivered crossed the shaped link between the two reads
    (with shared memory on, none would reach it), and no faster than the link's rate
    over the time around them (an unshaped veth carries many times it). Taken around
    the run, these need no timing of a read: on a busy machine, a read of tc's counters
    can come half a second after the call that makes it."""
    started = time.monotonic()
    before = channel.uplink().sent_bytes
    outcome = measure(channel, spec, workdir)
    crossed = channel.uplink().sent_bytes - before
    around = time.monotonic() - started
    assert all(f.deliveries >= 5 for f in outcome.result.followers), outcome.result.followers
    record = read_record(workdir / f"{spec.label}-n{spec.n}-b{spec.batch}.csv")
    assert crossed >= sum(map(len, record.values())) * FRAME_BYTES
    assert crossed <= channel.spec.rate_bps / 8 * around + channel.spec.burst_bytes
    return outcome


def test_wiswarm_frames_cross_the_shaped_link_and_stay_fresh(tmp_path: Path) -> None:
    with Channel() as channel:
        outcome = _measure_across(channel, RunSpec("wiswarm", 2, duration=3.0, warmup=1.5),
                                  tmp_path / "not" / "made")  # measure makes it
    # two followers share a 21 ms frame time: the round-robin floor is about 42 ms
    assert outcome.result.mean("mean_aoi_s") < 0.1
    assert outcome.complete and not outcome.events


def test_on_the_shared_channel_in_flight_auto_keeps_one_poll_out(tmp_path: Path) -> None:
    """Every poll crosses the one shaped uplink: a second poll out would only queue
    behind the first (throughput about 1.1 x at N = 3, where it must be 1.4 x to pay),
    so the leader keeps one, and the frames still cross and stay fresh."""
    with Channel() as channel:
        outcome = _measure_across(channel, RunSpec("wiswarm", 3, in_flight="auto",
                                                   duration=4.0, warmup=1.5), tmp_path)
    assert outcome.result.channel["in_flight"] == 1.0
    assert outcome.result.mean("mean_aoi_s") < 0.15


def test_push_frames_cross_the_shaped_link(tmp_path: Path) -> None:
    with Channel() as channel:
        _measure_across(channel, RunSpec("push-block", 2, rate=10.0, duration=3.0,
                                         warmup=1.5), tmp_path)


class _Faults:
    """Kills the followers' process, then lowers the channel's rate, at times from the
    run's first tick (its nodes ready, however long they took to start on a busy
    machine), on timers of their own: the run's supervising loop reads the channel with
    tc calls, seconds apart when loaded, and must not set when the faults come. Keeps
    when the kill was."""

    def __init__(self, channel: Channel, kill_at: float, rate_at: float) -> None:
        self._timers = [threading.Timer(kill_at, self._kill),
                        threading.Timer(rate_at, channel.set_rate, (5_000_000,))]
        self.killed_at: float | None = None  # wall clock, as the record's stamps
        self._started = False

    def __call__(self, fraction: float) -> None:
        if not self._started:
            self._started = True
            for timer in self._timers:
                timer.start()

    def _kill(self) -> None:
        followers = [p for p in multiprocessing.active_children() if p.name == "followers"]
        assert followers and followers[0].pid is not None
        self.killed_at = time.time()
        os.kill(followers[0].pid, signal.SIGKILL)

    def join(self) -> None:
        for timer in self._timers:
            timer.join()


def test_a_killed_follower_process_and_a_rate_change_are_survived_and_reported(
        tmp_path: Path) -> None:
    spec = RunSpec("wiswarm", 2, duration=12.0, warmup=1.0)
    with Channel() as channel:
        faults = _Faults(channel, kill_at=2.0, rate_at=4.0)
        outcome = measure(channel, spec, tmp_path, on_tick=faults)
        faults.join()
    events = " ".join(outcome.events)
    assert "followers process failed: it ended during the run (killed by signal 9); " \
        "started again" in events
    assert outcome.failed == 1
    assert "20mbit/20mbit -> 5mbit/5mbit" in events
    assert faults.killed_at is not None
    # the run went on: frames taken after the kill came from the process started again
    record = read_record(tmp_path / f"{spec.label}-n{spec.n}-b{spec.batch}.csv")
    after = {f: sum(generated > faults.killed_at for _, generated in record[f])
             for f in spec.followers}
    assert all(count >= 5 for count in after.values()), after


def test_a_udp_run_after_a_udp_run_at_50_fps_delivers(tmp_path: Path) -> None:
    """UDP at 50 fps over a full link leaves the leader side's reassembly memory full of
    incomplete datagrams for 30 s; a run in the same namespaces then delivered nothing.
    The study gives every run fresh namespaces: the next run at a rate the link carries
    gets every frame, and the reassembly counters show both."""
    first = measure_fresh(ChannelSpec(), RunSpec("udp", 8, rate=50.0, duration=3.0,
                                                 warmup=1.0), tmp_path, threading.Event())
    # the contamination it leaves (thousands on a quiet machine; 74 loaded, its senders slow)
    assert first.result.channel["reasm_fails"] > 0
    after = measure_fresh(ChannelSpec(), RunSpec("udp", 8, rate=5.0, duration=3.0,
                                                 warmup=1.0), tmp_path, threading.Event())
    counters = after.result.channel
    assert (counters["uplink_drops"], counters["reasm_fails"]) == (0.0, 0.0), counters
    # every frame is one datagram reassembled; the counters are read (by a process
    # started in the namespace) late on a busy machine, so they cover a window a little
    # off the one the deliveries are counted in: half the frames is what a working
    # count shows at any load
    assert counters["reasm_oks"] >= 8 * 5 * 3 * 0.5, counters
    assert all(f.deliveries >= 5 * 3 * 0.8 for f in after.result.followers), \
        after.result.followers
    assert not after.events


def _idle(stop: StopSignal, ready: ReadySignal) -> None:
    ready.set()
    stop.wait()


def _fails_when_stopped(stop: StopSignal, ready: ReadySignal) -> None:
    _idle(stop, ready)
    raise RuntimeError("Already borrowed")  # as the push baselines' teardown did


def _nodes_failing_at_stop(children: Children, place: Placement, spec: RunSpec,
                           record: Path, groups: list[Group]) -> None:
    for name in ("router", "leader"):
        children.start(name, _idle)
    for name, _, _ in groups:  # on the tbf channel: one, "followers"
        children.start(name, _fails_when_stopped)


def test_a_process_that_ends_with_an_error_when_stopped_is_reported(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(run_module, "_start_nodes", _nodes_failing_at_stop)
    with Channel() as channel:
        outcome = measure(channel, RunSpec("push-block", 2, duration=1.0, warmup=0.5),
                          tmp_path)
    assert [e.split(": ", 1)[1] for e in outcome.events] == [
        "followers process failed: exit code 1"]
    assert outcome.failed == 1


def _wait_for_rows(path: Path, rows: int, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not (path.exists() and len(path.read_text().splitlines()) > rows):
        assert time.monotonic() < deadline, f"{path} did not get {rows} rows"
        time.sleep(0.1)


def test_an_interrupted_study_writes_what_it_measured_and_removes_its_channels(
        tmp_path: Path) -> None:
    before = set(list_channels())
    out = tmp_path / "study"
    proc = subprocess.Popen(
        [sys.executable, "-m", "wiswarm_zenoh.cli.main", "experiment", "testbed", "--ns", "2",
         "--baselines", "udp", "--duration", "30", "--warmup", "1", "--parallel", "1",
         "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    _wait_for_rows(out / "records" / "wiswarm-n2-b0.csv", rows=100)  # past the warm-up
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C reaches the whole process group
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Interrupted" in (out / "gains.md").read_text()
    rows = (out / "runs.csv").read_text().splitlines()
    assert len(rows) >= 2 and rows[1].startswith("wiswarm,2,")
    assert left_behind(before) == []
