"""The user-space shared link against the tbf channel it emulates: the tracking demo's
mean AoI for WiSwarm and for push at 50 frames/s over each, at N = 4 and 8 (target:
user-space within 20 % of tbf for both systems), and the rate the link carries for
bulk TCP connections through it, against its nominal rate (target: within 10 %).

Each demo run is a fresh ``wiswarm demo --system S --channel user|tbf`` process (the
tbf channel needs root: without it only the user-space runs are made). Push's AoI
grows through a run as its queues fill (seconds; at N = 8 about 12 s), so the window
must be longer than that for the two channels to be told apart: 30 s by default.

    .venv/bin/python benchmarks/bench_user_link.py                 # about 5 minutes
    .venv/bin/python benchmarks/bench_user_link.py --ns 4 --duration 15
"""

from __future__ import annotations

import argparse
import contextlib
import json
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from wiswarm_zenoh.testbed import ChannelSpec, TestbedUnavailable, check_available
from wiswarm_zenoh.testbed.relay import DelayRelay
from wiswarm_zenoh.testbed.shaper import SharedLink
from wiswarm_zenoh.units import format_rate, parse_rate

SYSTEMS = ("wiswarm", "push")
AGREEMENT = 0.20
RATE_SLACK = 0.10
LOCAL = "127.0.0.1"


def demo_aoi(system: str, channel: str, uavs: int, duration: float, rate: str) -> float:
    """Mean AoI (s) of one demo run, averaged over its UAVs."""
    with tempfile.TemporaryDirectory(prefix="bench-user-link-") as out:
        argv = [sys.executable, "-m", "wiswarm_zenoh.cli.main", "demo", "--system", system,
                "--channel", channel, "--channel-rate", rate, "--uavs", str(uavs),
                "--duration", str(duration), "--no-live", "--no-dashboard", "--no-gif",
                "--out", out]
        done = subprocess.run(argv, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(argv[3:])} failed: {done.stderr[-2000:]}")
        summary = json.loads((Path(out) / "summary.json").read_text())
    return float(summary["systems"][system]["mean_aoi_s"])


def bulk_rate(spec: ChannelSpec, connections: int, seconds: float) -> float:
    """Wire bits/s the link lets out while ``connections`` TCP streams fill it, measured
    by its own counters after the first second (the bucket's burst)."""
    with socket.create_server((LOCAL, 0)) as server:
        server.listen(connections)
        link = SharedLink(spec)
        stop = threading.Event()
        with DelayRelay((LOCAL, 0), server.getsockname(), 0.0, link=link) as relay:
            def send() -> None:  # until the relay stops and resets the connection
                with contextlib.suppress(OSError), socket.create_connection(
                        (LOCAL, relay.port)) as sock:
                    block = bytes(64 * 1024)
                    while not stop.is_set():
                        sock.sendall(block)

            def drain(sock: socket.socket) -> None:
                with contextlib.suppress(OSError), sock:
                    while sock.recv(1 << 20):
                        pass

            threads = [threading.Thread(target=send, daemon=True) for _ in range(connections)]
            for thread in threads:
                thread.start()
            for _ in range(connections):
                threading.Thread(target=drain, args=(server.accept()[0],), daemon=True).start()
            time.sleep(1.0)
            first, start = link.up.counters().sent_bytes, time.monotonic()
            time.sleep(seconds)
            carried = (link.up.counters().sent_bytes - first) * 8 / (time.monotonic() - start)
            stop.set()
    return carried


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ns", default="4,8", help="numbers of UAVs (default 4,8)")
    parser.add_argument("--duration", type=float, default=30.0, help="s measured per run")
    parser.add_argument("--rate", default="20mbit", help="the channel's rate (default 20mbit)")
    args = parser.parse_args()
    ns = [int(n) for n in args.ns.split(",")]
    try:
        check_available()
        channels = ("user", "tbf")
    except TestbedUnavailable as exc:
        print(f"tbf channel unavailable ({exc}): user-space runs only")
        channels = ("user",)

    spec = ChannelSpec(rate_bps=parse_rate(args.rate))
    print(f"link rate, bulk TCP streams through the user-space link at "
          f"{format_rate(spec.rate_bps)} (wire bytes, as tbf counts them):")
    for connections in (1, 4, 8):
        carried = bulk_rate(spec, connections, 3.0)
        ratio = carried / spec.rate_bps
        print(f"  {connections} connection(s): {carried / 1e6:6.2f} Mbit/s = {ratio:.3f} of "
              f"nominal ({'met' if abs(ratio - 1) <= RATE_SLACK else 'MISSED'})", flush=True)

    print(f"\nmean AoI of the tracking demo, {args.duration:g} s per run, "
          f"{args.rate} (ms):")
    print(f"{'N':>3} {'system':>8} " + "".join(f"{c:>10}" for c in channels)
          + ("   user/tbf" if len(channels) == 2 else ""))
    for n in ns:
        for system in SYSTEMS:
            aoi = {c: demo_aoi(system, c, n, args.duration, args.rate) for c in channels}
            line = f"{n:>3} {system:>8} " + "".join(f"{aoi[c] * 1e3:10.1f}" for c in channels)
            if len(channels) == 2:
                ratio = aoi["user"] / aoi["tbf"]
                line += f"   {ratio:8.3f} ({'met' if abs(ratio - 1) <= AGREEMENT else 'MISSED'})"
            print(line, flush=True)


if __name__ == "__main__":
    main()
