"""The dashboard's page under load: frames drawn per second in headless Chromium with
100 followers, and how long a delivery takes from the leader to the page.

A stand-in leader in a process of its own (spawn) publishes what a real one does: the
delivery stream (JSON batches at 10 Hz: each follower polled in turn at ``--polls``
polls/s in all, its 100 Hz camera's freshest frame delivered, one poll in 50 unanswered),
every follower's stats and the leader's, at 2.5 Hz. A router and the dashboard run
here; the page counts its own frames (``window.wiswarm.frames``). The issue's targets:
at least 10 frames/s with 100 followers; a delivery on the page within 200 ms.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import random
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from wiswarm_zenoh.dashboard import Dashboard
from wiswarm_zenoh.transport import SessionSpec, free_tcp_port

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' browser driver
from tests.dashboard.browser import Browser

SWARM = "bench"
CAMERA_HZ = 100.0
TIMEOUT_SHARE = 0.02
BATCH_S = 0.1
STATS_S = 0.4
WINDOW_S = 30.0  # the sawtooth's: frames are counted once it is full
NO_SHM = ("transport/shared_memory/enabled:false",)


def spec(mode: str, port: int) -> SessionSpec:
    base = (SessionSpec.loopback("router", port) if mode == "router"
            else SessionSpec.loopback(mode, connect_ports=[port]))
    return SessionSpec(mode=base.mode, connect=base.connect, listen=base.listen,
                       multicast_scouting=False, cfg=NO_SHM)


def leader(port: int, followers: int, polls: float, stop: Any) -> None:
    """The stand-in leader until ``stop`` is set."""
    names = [f"f{i:03d}" for i in range(followers)]
    rng = random.Random(1)
    counts = dict.fromkeys(names, 0)
    start = time.time()
    with spec("peer", port).open() as session:
        deliveries = session.declare_publisher(f"wiswarm/{SWARM}/leader/deliveries")
        next_stats, turn, clock = start, 0, start
        while not stop.is_set():
            time.sleep(BATCH_S)
            now, batch = time.time(), []
            while clock < now:  # the polls of the last batch period, one follower each
                name = names[turn % followers]
                turn += 1
                counts[name] += 1
                if rng.random() < TIMEOUT_SHARE:
                    batch.append({"follower": name, "outcome": "timeout",
                                  "generated_at": None, "delivered_at": clock})
                else:
                    frame = clock - rng.uniform(0.0, 1.0 / CAMERA_HZ) - 0.002
                    batch.append({"follower": name, "outcome": "delivered",
                                  "generated_at": frame, "delivered_at": clock})
                clock += 1.0 / polls
            deliveries.put(json.dumps(batch))
            if now >= next_stats:
                next_stats = now + STATS_S
                for name in names:
                    session.put(f"wiswarm/{SWARM}/{name}/stats", json.dumps({
                        "follower": name, "aoi_s": 0.01, "mean_aoi_s": 0.02,
                        "p95_aoi_s": 0.05, "p_hat": 0.98, "weight": 1.0,
                        "polls": counts[name], "deliveries": counts[name],
                        "timeouts": 0, "errors": 0}))
                session.put(f"wiswarm/{SWARM}/leader/stats", json.dumps({
                    "followers": names, "polls_per_s": polls, "mean_aoi_s": 0.02,
                    "policy": "stand-in", "uptime_s": now - start, "leader": "bench",
                    "epoch": 1}))


def measure(followers: int, polls: float, seconds: float, screenshot: Path | None
            ) -> dict[str, float]:
    port = free_tcp_port()
    context = multiprocessing.get_context("spawn")
    stop = context.Event()
    with spec("router", port).open(), \
            Dashboard(spec("peer", port).open(), SWARM, port=0) as dashboard:
        feeder = context.Process(target=leader, args=(port, followers, polls, stop))
        feeder.start()
        browser = Browser()
        try:
            browser.open(dashboard.url)
            browser.wait_for(f"{followers} rows",
                             "document.querySelectorAll('#followers tbody tr').length",
                             timeout=60, accept=lambda rows: rows == followers)
            browser.wait_for("the 30 s window full", "wiswarm.latencies.length",
                             timeout=90, accept=lambda n: n >= WINDOW_S / BATCH_S)
            before, started = browser.evaluate("wiswarm.frames"), time.monotonic()
            time.sleep(seconds)  # the page draws meanwhile: its frames are counted
            frames = browser.evaluate("wiswarm.frames") - before
            elapsed = time.monotonic() - started
            latencies = browser.evaluate("wiswarm.latencies")
            newest = browser.evaluate("wiswarm.newestLatencies")
            if screenshot is not None:
                screenshot.write_bytes(browser.screenshot())
            errors = list(browser.errors)
        finally:
            browser.close()
            stop.set()
            feeder.join(10)
    if errors:
        print(f"console errors: {errors}")
    return {"fps": frames / elapsed, "median_s": statistics.median(latencies),
            "p95_s": statistics.quantiles(latencies, n=20)[-1],
            "newest_s": statistics.median(newest)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--followers", type=int, default=100, help="followers (default 100)")
    parser.add_argument("--polls", type=float, default=1000.0,
                        help="polls per second, all followers (default 1000)")
    parser.add_argument("--seconds", type=float, default=10.0,
                        help="how long frames are counted (default 10)")
    parser.add_argument("--screenshot", type=Path, help="save the page as this PNG")
    args = parser.parse_args()
    result = measure(args.followers, args.polls, args.seconds, args.screenshot)
    print(f"{args.followers} followers, {args.polls:g} polls/s: "
          f"{result['fps']:.1f} frames/s drawn (target >= 10); delivery to page: "
          f"median {result['median_s'] * 1e3:.0f} ms, p95 {result['p95_s'] * 1e3:.0f} ms "
          f"(a batch's oldest delivery; its newest: median {result['newest_s'] * 1e3:.0f} "
          "ms); target 200 ms")


if __name__ == "__main__":
    main()
