"""The WiFi medium (ns-3's 802.11 through taps, in real time): a WiSwarm swarm and a push
baseline cross it with each follower a station, its counters add up, and nothing is left
behind, also when the medium's owner is killed."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import select
import signal
import threading
from multiprocessing.synchronize import Event
from pathlib import Path

import pytest

from wiswarm_zenoh.cli import main as cli
from wiswarm_zenoh.programs.frames import FRAME_BYTES
from wiswarm_zenoh.testbed.ns3_build import unavailable_reason
from wiswarm_zenoh.testbed.ownership import namespace_exists, process_start
from wiswarm_zenoh.testbed.run import RunSpec, measure
from wiswarm_zenoh.testbed.wifi import WifiMedium
from wiswarm_zenoh.testbed.wifi_records import cleanup_leftovers, list_media
from wiswarm_zenoh.testbed.wifi_spec import MediumFailed, WifiSpec

NS3_MISSING = unavailable_reason()
pytestmark = [pytest.mark.testbed,
              pytest.mark.skipif(NS3_MISSING is not None, reason=f"ns-3: {NS3_MISSING}")]
STATIONS = 3
FRAGMENTS = -(-FRAME_BYTES // 1448)  # TCP segments of one frame, at least


def _crossed(medium: WifiMedium, system: str, rate: float, tmp_path: Path) -> None:
    outcome = measure(medium, RunSpec(system, STATIONS, rate=rate, duration=3.0,
                                      warmup=2.0), tmp_path)
    result, air = outcome.result, outcome.result.channel
    assert all(f.deliveries >= 3 for f in result.followers), result.followers
    delivered = sum(f.deliveries for f in result.followers)
    # every delivered frame went through the stations' taps onto the simulated air
    assert air["uplink_frames_per_s"] * result.duration >= delivered * FRAGMENTS * 0.9
    assert air["airtime_share"] > 0
    assert air["max_lag_ms"] < medium.spec.hard_limit_ms
    assert outcome.complete and not outcome.events


def test_a_swarm_and_push_cross_the_wifi_medium_and_leave_nothing(tmp_path: Path) -> None:
    with WifiMedium(WifiSpec(stations=STATIONS), name=f"w28t{os.getpid():x}") as medium:
        assert len(medium.station_namespaces) == STATIONS
        _crossed(medium, "wiswarm", 100.0, tmp_path)
        _crossed(medium, "push-block", 5.0, tmp_path)
        run_id = medium.run_id
        names = [medium.leader_ns, *medium.station_namespaces]
    assert run_id not in list_media()
    assert not any(namespace_exists(ns) for ns in names)


def _own_medium(run_id: str, up: Event) -> None:
    """A process that builds a medium and waits to be killed."""
    with WifiMedium(WifiSpec(stations=1), name=run_id):
        up.set()
        threading.Event().wait()


def test_a_killed_owners_medium_and_scenario_are_removed() -> None:
    ctx = multiprocessing.get_context("spawn")
    up = ctx.Event()
    run_id = f"w28k{os.getpid():x}"
    owner = ctx.Process(target=_own_medium, args=(run_id, up))
    owner.start()
    try:
        assert up.wait(60), "the medium was not built"
        pid, start = WifiMedium.attach(run_id).scenario_process
        os.kill(owner.pid or 0, signal.SIGKILL)
        owner.join()
        assert run_id in list_media()
        assert run_id in cleanup_leftovers()
    finally:
        owner.kill()
    assert run_id not in list_media()
    assert process_start(pid) != start


def test_falling_behind_real_time_fails_loudly() -> None:
    """A hard limit no simulation keeps (1 us): the scenario ends itself, and the next
    check says the medium fell behind real time, by how much."""
    with WifiMedium(WifiSpec(stations=1, hard_limit_ms=0.001),
                    name=f"w28l{os.getpid():x}") as medium:
        pid, _ = medium.scenario_process
        with contextlib.suppress(ProcessLookupError):  # ended already
            handle = os.pidfd_open(pid)
            try:
                assert select.select([handle], [], [], 30)[0], "the scenario kept running"
            finally:
                os.close(handle)
        with pytest.raises(MediumFailed, match="behind real time"):
            medium.check()


def test_up_status_down_by_hand(capsys: pytest.CaptureFixture[str]) -> None:
    """`testbed up --medium wifi` leaves a medium that outlives the command, `status`
    shows its lag and air, `down RUN_ID` removes it and its scenario."""
    run_id = f"w28c{os.getpid():x}"
    assert cli.main(["testbed", "up", "--medium", "wifi", "--stations", "1",
                     "--name", run_id]) == 0
    try:
        assert f"wsw28-{run_id}-s1" in capsys.readouterr().out
        pid, start = WifiMedium.attach(run_id).scenario_process
        assert process_start(pid) == start  # persistent: its scenario runs on
        assert cli.main(["testbed", "status"]) == 0
        status = capsys.readouterr().out
        assert f"WiFi medium {run_id}, persistent" in status and "air: " in status
    finally:
        assert cli.main(["testbed", "down", run_id]) == 0
    assert capsys.readouterr().out == f"removed WiFi medium {run_id}\n"
    assert run_id not in list_media()
    assert process_start(pid) != start
