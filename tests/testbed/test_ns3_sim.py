"""The ns-3 scenario as a plain simulation: the workloads it generates give the AoI the
air allows, and a sender without a blocking socket loses whole frames where one with it
only waits (what the taps cannot give real processes). Needs ns-3, not root."""

from __future__ import annotations

import pytest

from wiswarm_zenoh.testbed.ns3_build import unavailable_reason
from wiswarm_zenoh.testbed.ns3_sim import Ns3Run, run_ns3

NS3_MISSING = unavailable_reason()
pytestmark = pytest.mark.skipif(NS3_MISSING is not None, reason=f"ns-3: {NS3_MISSING}")


def test_round_robin_polls_keep_every_station_at_the_airs_pace() -> None:
    result = run_ns3(Ns3Run(4, "wiswarm", window_s=3.0))
    # 35 fragments of 1472 B at 65 Mbit/s: about 11 ms a frame on air, 4 stations
    assert 10 < result.frames_per_s < 30
    assert 0.02 < result.mean_aoi_s < 0.1


def test_without_a_blocking_socket_an_overloaded_station_loses_whole_frames() -> None:
    blocking = run_ns3(Ns3Run(4, "push", rate=50.0, window_s=3.0))
    raw = run_ns3(Ns3Run(4, "push", rate=50.0, window_s=3.0, blocking=False))
    assert blocking.frames_per_s > 10 * max(raw.frames_per_s, 0.1)
    assert raw.loss > 0.9
