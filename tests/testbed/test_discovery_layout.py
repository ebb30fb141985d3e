"""The guide's two-router layout as a user runs it (issue 40): real ``wiswarm``
processes, a robot router dialing the ground's, the follower on the robot's router and
the leader on the ground's, a busy loop beside them. The leader restarted 20 times with
the follower up, then both started together 20 times: each join within 2 s of both
being up, every time, in peer mode and in client mode. ``benchmarks/bench_discovery.py``
is the count; this runs it as a user would and reads its verdict. It is here, in the
testbed's unit (``tests/conftest.py``), so that its busy loop never runs beside the
channel tests' rate measurements."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_discovery.py"
TRIALS = 20


@pytest.mark.parametrize("mode", ["peer", "client"])
def test_every_join_within_2_s_in_the_two_router_layout(mode: str) -> None:
    done = subprocess.run(
        [sys.executable, str(BENCH), "--modes", mode, "--trials", str(TRIALS), "--busy", "1",
         "--within", "2", "--check"], capture_output=True, text=True, timeout=600)
    counts = re.findall(r"(restart|together)\s+(\d+) of (\d+) missed", done.stdout)
    assert [(kind, int(total)) for kind, _, total in counts] == \
        [("restart", TRIALS), ("together", TRIALS)], done.stdout + done.stderr
    assert [int(missed) for _, missed, _ in counts] == [0, 0], done.stdout
    assert done.returncode == 0, done.stdout + done.stderr
