"""`wiswarm demo --keep-dashboard`: once both runs are over and compared, each run's
dashboard goes on serving the run's end (its follower, its deliveries, marked finished)
until Ctrl-C, which ends the demo cleanly and takes the pages down.

Its own short run (one UAV, 1 s each, bare loopback: about 10 s): the comparison's
fixture runs without the dashboard, as an unprivileged user, to completion."""

from __future__ import annotations

import asyncio
import json
import re
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import aiohttp
import pytest

from wiswarm_zenoh.testbed.faults import Process

WAIT = 45.0  # seconds for both runs to end and the pages to be announced (about 10 s)
SERVING = re.compile(r"^dashboards of the finished runs: wiswarm (http://\S+/), "
                     r"push (http://\S+/) \(Ctrl-C to stop\)$")


@pytest.fixture
def demo(tmp_path: Path) -> Iterator[Process]:
    """``wiswarm demo`` as a user starts it, its output read line by line."""
    running = Process("demo", ["demo", "--uavs", "1", "--duration", "1", "--warmup", "0.5",
                               "--channel", "none", "--no-live", "--no-gif",
                               "--keep-dashboard", "--out", str(tmp_path / "run")],
                      cwd=tmp_path)
    try:
        yield running
    finally:
        if running.popen.poll() is None:
            running.popen.kill()
        running.popen.wait()
        running.read_to_end(WAIT)


def visit(url: str) -> tuple[str, dict[str, Any]]:
    """What a browser gets from ``url``: the page, and the first message of its feed
    (the snapshot of everything the dashboard holds)."""
    async def get() -> tuple[str, dict[str, Any]]:
        timeout = aiohttp.ClientTimeout(total=WAIT)
        async with aiohttp.ClientSession(timeout=timeout) as http:
            async with http.get(url) as reply:
                assert reply.status == 200
                page = await reply.text()
            async with http.ws_connect(url + "ws") as ws:
                return page, json.loads(await ws.receive_str())[0]
    return asyncio.run(get())


def test_the_finished_runs_stay_on_view_until_ctrl_c(demo: Process, tmp_path: Path) -> None:
    serving = SERVING.match(demo.wait_for("dashboards of the finished runs", timeout=WAIT))
    assert serving is not None, "\n".join(demo.lines[-40:])
    assert demo.popen.poll() is None  # the runs are over; the demo is not
    assert (tmp_path / "run" / "summary.json").exists()  # compared and written first
    assert any(line.startswith("AoI mean (ms)") for line in demo.lines)
    wiswarm_url, push_url = serving.groups()
    assert wiswarm_url != push_url

    page, wiswarm = visit(wiswarm_url)
    assert "WiSwarm dashboard" in page
    assert wiswarm["type"] == "snapshot" and wiswarm["swarm"] == "tracking"
    status = wiswarm["status"]
    assert status["finished_at"] is not None and not status["leader_alive"]
    records = wiswarm["traces"]["uav0"]["records"]  # the run's delivery stream, kept
    assert len(records) >= 50  # 100 frames/s for 1 s, polled
    assert all(delivered <= status["finished_at"] for _, delivered in records)
    assert [s["follower"] for s in wiswarm["stats"]] == ["uav0"]
    assert [t["uav"] for t in wiswarm["tracking"]] == ["uav0"]

    _, push = visit(push_url)  # the baseline's: its receiver's stats and the arena
    assert push["status"]["finished_at"] is not None
    assert [s["follower"] for s in push["stats"]] == ["uav0"]
    assert [t["uav"] for t in push["tracking"]] == ["uav0"]

    demo.popen.send_signal(signal.SIGINT)
    assert demo.popen.wait(WAIT) == 0, "\n".join(demo.lines[-40:])
    assert not any("Traceback" in line for line in demo.lines), "\n".join(demo.lines)
    for url in (wiswarm_url, push_url):  # the pages went with it
        with pytest.raises(aiohttp.ClientConnectionError):
            visit(url)
