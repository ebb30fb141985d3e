"""``benchmarks/bench_soak.py`` in short (25 s, every period a fifth of the real run's,
2 steady followers): the churn, the hung follower and the leader's restart leave no
process dead, no descriptor or thread behind in the router or the leader, no Zenoh
segment anywhere (shared memory is off by default), and every steady follower
delivering in every interval. The rates and memory of the half-hour run are in
docs/measurements.md."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_a_short_soak_leaves_nothing_behind(tmp_path: Path) -> None:
    run = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_soak.py"), "--minutes", "0.4",
         "--steady", "2", "--time-scale", "0.2", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["surprises"] == []
    assert summary["segments_mapped"] == 0 and summary["segments_left"] == []
    assert summary["fds_and_threads_flat"]
    assert "leader kill" in " ".join(row["events"] for row in summary["rows"])
    assert all(row["min_rate_ratio"] > 0 for row in summary["rows"])
    assert summary["resumed_after_leader_kill_s"] is not None
    assert (tmp_path / "soak.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
