"""The page in a real browser (headless Chromium) against a real swarm on loopback: a
leader and three followers whose cameras run at 20, 10 and 5 Hz, so each sawtooth has
teeth of its own. Skipped, saying why, where Chromium is not installed."""

from __future__ import annotations

import multiprocessing
import statistics
import time
from collections.abc import Iterator
from contextlib import ExitStack

import cv2
import numpy as np
import pytest

from tests.transport.helpers import Sessions
from wiswarm_zenoh.core import FollowerConfig
from wiswarm_zenoh.dashboard import Dashboard
from wiswarm_zenoh.programs import Children
from wiswarm_zenoh.programs.runners import (
    FollowerOptions,
    LeaderOptions,
    run_followers,
    run_leader,
)

from .browser import Browser
from .conftest import loopback

SWARM = "live"
LEADER = "edge-a"
CAMERAS = {"f1": 20.0, "f2": 10.0, "f3": 5.0}  # frames/s
ROWS = "[...document.querySelectorAll('#followers tbody tr')].map(r => r.dataset.follower)"
PLOT = ("(() => { const r = document.querySelector('#sawtooth canvas')"
        ".getBoundingClientRect(); return {x: r.x, y: r.y, width: r.width, "
        "height: r.height}; })()")
LATENCY_TARGET_S = 0.2


class Swarm:
    """The followers of CAMERAS in one child process and the leader in another (spawn):
    the test's process holds the router, the dashboard and the browser's client only,
    as a dashboard on its own machine would."""

    def __init__(self, port: int) -> None:
        context = multiprocessing.get_context("spawn")
        spec = loopback("peer", port)
        self._stack = ExitStack()
        followers = self._stack.enter_context(Children(context))
        leader = self._stack.enter_context(Children(context))
        followers.start("followers", run_followers, spec, [
            FollowerOptions(SWARM, follower, FollowerConfig(queue="lifo", capacity=1),
                            frame_bytes=1000, frame_rate=rate)
            for follower, rate in CAMERAS.items()], wait=False)
        leader.start("leader", run_leader, spec, LeaderOptions(SWARM, name=LEADER), wait=False)
        followers.wait_ready()
        leader.wait_ready()

    def close(self) -> None:
        """Both processes are stopped (again: nothing more)."""
        self._stack.close()


@pytest.fixture
def swarm(sessions: Sessions, port: int) -> Iterator[Swarm]:
    running = Swarm(port)
    yield running
    running.close()


def coloured_pixels(png: bytes) -> int:
    """Pixels of a saturated colour: the series' lines (axes and grid are grey)."""
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    saturation = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)[:, :, 1]
    return int(np.count_nonzero(saturation > 80))


def changed_share(first: bytes, second: bytes) -> float:
    a, b = (cv2.imdecode(np.frombuffer(p, np.uint8), cv2.IMREAD_COLOR) for p in (first, second))
    assert a.shape == b.shape
    return float(np.count_nonzero(np.any(a != b, axis=2))) / (a.shape[0] * a.shape[1])


def test_the_page_shows_the_swarm_live_and_survives_its_going(
        browser: Browser, swarm: Swarm, sessions: Sessions, port: int) -> None:
    with Dashboard(sessions.open(loopback("peer", port)), SWARM, port=0) as dashboard:
        browser.open(dashboard.url)
        browser.wait_for("the table to list the three followers", ROWS,
                         accept=lambda rows: sorted(rows) == sorted(CAMERAS))
        browser.wait_for("a delivery drawn", "wiswarm.lastDelivery")
        browser.wait_for("the leader named", "document.getElementById('leader').textContent",
                         accept=lambda text: LEADER in text)
        clip = browser.evaluate(PLOT)
        first = browser.screenshot(clip)
        time.sleep(1.0)  # the test's own interval: a second of swarm between the two
        second = browser.screenshot(clip)
        assert coloured_pixels(second) > 500, "no sawtooth drawn"
        assert changed_share(first, second) > 0.01, "the sawtooth did not move in a second"

        # Each drawn batch: from its oldest delivery at the leader to the frame showing it.
        latencies = browser.wait_for("20 batches drawn", "wiswarm.latencies",
                                     accept=lambda values: len(values) >= 20)
        median = statistics.median(latencies)
        newest = statistics.median(browser.evaluate("wiswarm.newestLatencies"))
        print(f"delivery to page: median {median * 1e3:.0f} ms, max {max(latencies) * 1e3:.0f} "
              f"ms over {len(latencies)} batches (their oldest delivery; their newest: median "
              f"{newest * 1e3:.0f} ms); {browser.evaluate('wiswarm.fps'):.0f} fps")
        assert median < LATENCY_TARGET_S

        # A browser that loses its connection comes back, from a snapshot.
        browser.evaluate("wiswarm.socket.close()")
        browser.wait_for("a second connection", "wiswarm.connects", accept=lambda n: n == 2)
        since = time.time()
        browser.wait_for("a delivery drawn after it", "wiswarm.lastDelivery.drawn_at",
                         accept=lambda drawn: drawn > since)
        assert sorted(browser.evaluate(ROWS)) == sorted(CAMERAS)

        # The swarm vanishes: the page says since when there is no leader.
        swarm.close()
        text = browser.wait_for("no leader", "document.getElementById('leader').textContent",
                                accept=lambda text: text.startswith("no leader since"))
        print(text)
    assert browser.errors == []
