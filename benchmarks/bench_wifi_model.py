"""Our 802.11 model (``sim``'s ``wifi`` channel) against ns-3's, in plain simulation.

The same scenarios in both: N = 4, 8, 14 stations and an access point on one 2.4 GHz
channel, 802.11n at MCS 7 (65 Mbit/s, long guard interval) without A-MPDU (our model
has none), error-free links (ns-3's stations stand 1 m apart), 49 kB frames, a MAC queue
of 128 packets; WiSwarm (polls, cameras at 100 fps) and UDP-like push at 50 fps (above
the air's share: queues overflow) and at 5 fps (below it), both through a blocking
socket as on Linux (frames wait in the application's FIFO). Mean AoI, delivered frames
per station per second and frame loss side by side, and the ratio of the means; a figure
of mean AoI against N. Also in ns-3: A-MPDU on (its default), to show what aggregation is
worth, and push without a blocking socket (each frame's fragments thrown at the MAC
queue, which drops what does not fit: what the testbed's taps give). Any speed, no root.
About three minutes.

    .venv/bin/python benchmarks/bench_wifi_model.py --figure docs/wifi_model_vs_ns3.png
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, replace
from pathlib import Path

from wiswarm_zenoh.sim.phy import WifiParams
from wiswarm_zenoh.sim.scenario import WifiScenario, run_wifi
from wiswarm_zenoh.testbed.ns3_build import unavailable_reason
from wiswarm_zenoh.testbed.ns3_sim import Ns3Result, Ns3Run, run_ns3

SYSTEMS = (("wiswarm", 100.0), ("push", 50.0), ("push", 5.0))
FRAME_BYTES = 50176
QUEUE = 128
AGREE = 1.25  # the bound on mean AoI: within 25 %


@dataclass(frozen=True)
class Row:
    n: int
    label: str
    ours: Ns3Result
    ns3: Ns3Result
    ns3_ampdu: Ns3Result
    ns3_raw: Ns3Result | None


def ours(n: int, system: str, rate: float, window: float) -> Ns3Result:
    """Our model on the same scenario (push is its UDP-like sender)."""
    result = run_wifi(WifiScenario(
        n=n, system="udp" if system == "push" else system, rate=rate,
        frame_bytes=FRAME_BYTES, duration=window, seed=1, reliability=(1.0, 1.0),
        host_delay=0.0, params=WifiParams(mcs=7, mac_queue=QUEUE)))
    fps = sum(f.throughput_fps for f in result.followers) / n
    return Ns3Result(result.mean("mean_aoi_s"), fps,
                     max(0.0, 1 - fps / rate) if system == "push" else 0.0,
                     result.channel["collision_share"])


def plot(path: Path, rows: list[Row]) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for i, label in enumerate(dict.fromkeys(r.label for r in rows)):
        mine = [r for r in rows if r.label == label]
        ns = [r.n for r in mine]
        color = f"C{i}"
        ax.plot(ns, [r.ns3.mean_aoi_s for r in mine], "o-", color=color,
                label=f"{label}: ns-3")
        ax.plot(ns, [r.ours.mean_aoi_s for r in mine], "s--", color=color,
                label=f"{label}: our model")
    ax.set_yscale("log")
    ax.set_xlabel("N (stations)")
    ax.set_ylabel("mean AoI per station (s)")
    ax.set_title("802.11n MCS 7, no A-MPDU: our model against ns-3")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ns", type=int, nargs="+", default=[4, 8, 14])
    parser.add_argument("--window", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--figure", type=Path, default=None)
    args = parser.parse_args()
    if (reason := unavailable_reason()) is not None:
        print(f"bench_wifi_model: {reason}", file=sys.stderr)
        return 2
    rows = []
    for n in args.ns:
        for system, rate in SYSTEMS:
            run = Ns3Run(n, system, rate, FRAME_BYTES, args.window, queue_packets=QUEUE)
            label = "wiswarm" if system == "wiswarm" else f"push@{rate:g}"
            rows.append(Row(n, label, ours(n, system, rate, args.window), run_ns3(run),
                            run_ns3(replace(run, ampdu=True)),
                            run_ns3(replace(run, blocking=False)) if system == "push"
                            else None))
            r = rows[-1]
            print(f"  N={n:2d} {label:>8}: ours {r.ours.mean_aoi_s:.3f} s, ns-3 "
                  f"{r.ns3.mean_aoi_s:.3f} s", file=sys.stderr)
    print("| N | system | mean AoI ours (s) | ns-3 (s) | ours / ns-3 | frames/s ours | ns-3 "
          "| loss ours | ns-3 | failed tx ours | ns-3 | ns-3 with A-MPDU: AoI (s) "
          "| ns-3, no blocking socket: AoI (s), frames/s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        ratio = r.ours.mean_aoi_s / r.ns3.mean_aoi_s
        flag = "" if 1 / AGREE <= ratio <= AGREE else " **"
        print(f"| {r.n} | {r.label} | {r.ours.mean_aoi_s:.3f} | {r.ns3.mean_aoi_s:.3f} | "
              f"{ratio:.2f}{flag} | {r.ours.frames_per_s:.2f} | {r.ns3.frames_per_s:.2f} | "
              f"{r.ours.loss:.2f} | {r.ns3.loss:.2f} | {r.ours.failed_tx_share:.3f} | "
              f"{r.ns3.failed_tx_share:.3f} | {r.ns3_ampdu.mean_aoi_s:.3f} | "
              + ("-" if r.ns3_raw is None else
                 f"{r.ns3_raw.mean_aoi_s:.3f}, {r.ns3_raw.frames_per_s:.2f}") + " |")
    print(f"\n** outside {AGREE:g}x either way")
    if args.figure is not None:
        plot(args.figure, rows)
        print(f"wrote {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
