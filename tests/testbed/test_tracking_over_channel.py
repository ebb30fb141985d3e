"""The tracking application with its UAVs behind the emulated channel: the demo records
the channel it ran over, and the flight study writes its figures and table."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from wiswarm_zenoh.testbed import list_channels

from .channel_helpers import left_behind

pytestmark = pytest.mark.testbed


def _wiswarm(*argv: str) -> subprocess.CompletedProcess[str]:
    """A fresh process: the demo opens its leader's session inside the channel's leader
    namespace, which only a process with no Zenoh session yet can do."""
    return subprocess.run([sys.executable, "-m", "wiswarm_zenoh.cli.main", *argv],
                          capture_output=True, text=True, timeout=180, check=False)


def test_the_demo_over_the_channel_tracks_and_records_the_channel(tmp_path: Path) -> None:
    before = set(list_channels())
    done = _wiswarm("demo", "--system", "wiswarm", "--channel", "tbf", "--channel-rate",
                    "20mbit", "--uavs", "2", "--duration", "4", "--warmup", "1", "--no-live",
                    "--no-gif", "--out", str(tmp_path))
    assert done.returncode == 0, done.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["channel"] == {"kind": "tbf", "rate_bps": 20_000_000,
                                  "down_rate_bps": 20_000_000, "queue_s": 0.2,
                                  "burst_bytes": 32768}
    assert summary["systems"]["wiswarm"]["channel"] == summary["channel"]
    # two UAVs share 21 ms frame times: about 45 ms, far from what push would show
    assert 0.02 < summary["average"]["mean_aoi_s"] < 0.2
    assert summary["leader"]["uavs_reporting"] == 2
    assert left_behind(before) == []


def test_the_flight_study_writes_its_figures_and_table(tmp_path: Path) -> None:
    done = _wiswarm("experiment", "tracking", "--ns", "1", "--duration", "2",
                    "--rates", "20,50", "--out", str(tmp_path))
    assert done.returncode == 0, done.stderr
    for name in ("runs.csv", "tracking_error.png", "aoi.png", "tracking.md"):
        assert (tmp_path / name).stat().st_size > 0
    table = (tmp_path / "tracking.md").read_text()
    assert "| 1 | wiswarm | 100 |" in table and "| 1 | push@50 | 50 |" in table
    assert "| 1 | push-opt |" in table


def test_a_bad_channel_rate_is_one_line() -> None:
    done = _wiswarm("demo", "--channel", "tbf", "--channel-rate", "fast")
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "rate 'fast' is not a rate" in done.stderr
