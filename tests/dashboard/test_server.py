"""The dashboard over real Zenoh sessions on loopback and a real WebSocket, without a
browser: what a page is sent, rogue input, a browser that goes and comes back, and the
command line."""

from __future__ import annotations

import asyncio
import json
import logging
import re
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

import aiohttp
import pytest
import zenoh

from tests.transport.helpers import WAIT, Sessions, wait_until_known
from wiswarm_zenoh.cli import main as cli
from wiswarm_zenoh.dashboard import Dashboard
from wiswarm_zenoh.transport import free_tcp_port

KEYS = {"deliveries": "wiswarm/d/leader/deliveries", "stats": "wiswarm/d/f1/stats",
        "tracking": "wiswarm/d/uav0/tracking", "points": "wiswarm/experiments/r1/points"}


def batch(*records: tuple[str, float | None, float]) -> str:
    return json.dumps([{"follower": f, "outcome": "timeout" if g is None else "delivered",
                        "generated_at": g, "delivered_at": d} for f, g, d in records])


class Page:
    """What a browser's WebSocket gets: the messages, by type, in order."""

    def __init__(self, ws: aiohttp.ClientWebSocketResponse) -> None:
        self.ws = ws
        self.messages: list[dict[str, Any]] = []

    async def next(self, kind: str) -> dict[str, Any]:
        """The next message of ``kind`` (statuses and others on the way are kept)."""
        async with asyncio.timeout(WAIT):
            while True:
                for message in json.loads(await self.ws.receive_str()):
                    self.messages.append(message)
                    if message["type"] == kind:
                        return message


def known(node: zenoh.Session) -> None:
    """Until the dashboard's subscribers are known to ``node``: a put before is lost."""
    for key in KEYS.values():
        wait_until_known(node, key)


def until(what: str, condition: Callable[[], bool]) -> None:
    """Poll with a deadline: samples reach the dashboard on Zenoh's threads."""
    deadline = time.monotonic() + WAIT
    while not condition():
        assert time.monotonic() < deadline, f"timed out: {what}"
        time.sleep(0.01)


def records(dashboard: Dashboard, follower: str) -> list[Any]:
    traces = dashboard.state.snapshot()[0]["traces"]
    return list(traces[follower]["records"]) if follower in traces else []


def test_a_page_gets_a_snapshot_then_every_change_and_comes_back(
        dashboard: Dashboard, node: zenoh.Session) -> None:
    known(node)
    node.put(KEYS["deliveries"], batch(("f1", 10.0, 10.2), ("f2", None, 10.3)))
    until("the first batch", lambda: bool(records(dashboard, "f2")))

    async def visit() -> None:
        async with aiohttp.ClientSession() as http:
            async with http.ws_connect(dashboard.url + "ws") as ws:
                page = Page(ws)
                assert (await page.next("snapshot"))["traces"] == {
                    "f1": {"tau": None, "records": [[10.0, 10.2]]},
                    "f2": {"tau": None, "records": [[None, 10.3]]}}
                node.put(KEYS["deliveries"], batch(("f1", 11.0, 11.1)))
                assert (await page.next("deliveries"))["records"] == [["f1", 11.0, 11.1]]
                node.put(KEYS["stats"], json.dumps({"follower": "f1", "aoi_s": float("inf"),
                                                    "polls": 3}))
                stats = (await page.next("stats"))["record"]
                assert stats == {"follower": "f1", "aoi_s": None, "polls": 3,
                                 "polls_per_s": None}
            node.put(KEYS["deliveries"], batch(("f2", 12.0, 12.5)))  # while it is away
            until("the batch sent while away", lambda: len(records(dashboard, "f2")) == 2)
            async with http.ws_connect(dashboard.url + "ws") as ws:
                traces = (await Page(ws).next("snapshot"))["traces"]
                assert traces["f1"]["records"] == [[10.0, 10.2], [11.0, 11.1]]
                assert traces["f2"]["records"] == [[None, 10.3], [12.0, 12.5]]

    asyncio.run(visit())


def test_rogue_json_is_counted_logged_with_its_key_and_skipped(
        dashboard: Dashboard, node: zenoh.Session, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING)
    known(node)
    for key in KEYS.values():
        node.put(key, b"\xff{not json")
    node.put(KEYS["deliveries"], json.dumps([{"follower": "f1", "outcome": "lost"}]))
    node.put(KEYS["stats"], json.dumps({"follower": "someone-else"}))
    node.put(KEYS["deliveries"], batch(("f1", 1.0, 1.5)))
    until("the good batch after the bad ones", lambda: bool(records(dashboard, "f1")))
    assert records(dashboard, "f1") == [(1.0, 1.5)]
    until("every bad message counted", lambda: dashboard.state.bad_input.total() == 6)
    assert dashboard.state.bad_input.counts == {KEYS["deliveries"]: 2, KEYS["stats"]: 2,
                                                KEYS["tracking"]: 1, KEYS["points"]: 1}
    logged = [r.getMessage() for r in caplog.records]
    for key in KEYS.values():
        assert any(f"bad input from {key}: not JSON" in line for line in logged), logged


def test_a_port_in_use_is_one_line_and_exit_2(
        sessions: Sessions, port: int, capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        used = taken.getsockname()[1]
        code = cli.main(["dashboard", "--port", str(used), "-e", f"tcp/127.0.0.1:{port}",
                         "--no-multicast-scouting", "--duration", "1"])
    err = capsys.readouterr().err.splitlines()
    assert code == 2
    assert len(err) == 1 and f"cannot serve on 127.0.0.1 port {used}" in err[0], err


def test_the_command_serves_the_page_and_its_files_offline(
        sessions: Sessions, port: int, capsys: pytest.CaptureFixture[str]) -> None:
    web = free_tcp_port()
    codes: list[int] = []
    command = threading.Thread(target=lambda: codes.append(cli.main([
        "dashboard", "--swarm", "s1", "--port", str(web), "-e", f"tcp/127.0.0.1:{port}",
        "--no-multicast-scouting", "--duration", "2"])))
    command.start()

    async def fetch() -> dict[str, str]:
        files = {}
        async with aiohttp.ClientSession(f"http://127.0.0.1:{web}") as http:
            async with asyncio.timeout(WAIT):
                while True:
                    try:
                        async with http.get("/") as reply:
                            files["/"] = await reply.text()
                            break
                    except aiohttp.ClientConnectionError:
                        await asyncio.sleep(0.05)  # not listening yet
            for name in ("uPlot.iife.min.js", "uPlot.min.css", "uPlot.LICENSE", "main.js",
                         "sawtooth.js", "table.js", "map.js", "experiments.js",
                         "dashboard.css"):
                async with http.get(f"/static/{name}") as reply:
                    assert reply.status == 200, name
                    files[name] = await reply.text()
        return files

    files = asyncio.run(fetch())
    command.join()
    assert codes == [0]
    assert f"swarm 's1' on http://127.0.0.1:{web}/" in capsys.readouterr().out
    assert "/static/uPlot.iife.min.js" in files["/"]
    for name in ("/", "main.js", "sawtooth.js", "table.js", "map.js", "experiments.js"):
        assert not re.search(r"https?://", files[name]), f"{name} loads from another site"
    assert "MIT License" in files["uPlot.LICENSE"]
    assert files["uPlot.iife.min.js"].startswith("/*! https://github.com/leeoniya/uPlot")
