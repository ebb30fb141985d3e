"""``--in-flight auto`` against hand-set K, where each is right (Linux, root):

- the edge-cloud experiment (2 sites x 6 followers, 50 Mbit/s WAN, 20 ms one way): the
  cloud leader's mean AoI with K = 1, the K that fills the WAN, one per pair, and auto
  (target: auto within 10 % of the best hand-set K);
- the testbed's shared 20 Mbit/s channel at N = 8 (every poll crosses one bottleneck):
  K = 1 against auto, alternating, ``--rounds`` runs each (target: within 5 %).

    .venv/bin/python benchmarks/bench_in_flight.py
    .venv/bin/python benchmarks/bench_in_flight.py --cases testbed --rounds 3
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path
from statistics import mean

from wiswarm_zenoh.core.config import InFlight
from wiswarm_zenoh.experiments.edge_cloud_run import EdgeCloudConfig, run_edge_cloud
from wiswarm_zenoh.testbed import ChannelSpec, TestbedUnavailable, check_available
from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.run import RunSpec, measure


def edge_cloud(duration: float) -> None:
    config = EdgeCloudConfig(duration=duration)
    ks: tuple[InFlight, ...] = (1, config.wan_in_flight(), config.pairs, "auto")
    config = EdgeCloudConfig(duration=duration, in_flight=ks)
    with tempfile.TemporaryDirectory() as tmp:
        results = run_edge_cloud(config, Path(tmp), lambda done, total: None)
    hierarchy = {r.setup.k: r.mean("mean_aoi_s") for r in results.results
                 if r.setup.kind == "hierarchy"}
    print(f"edge-cloud, {config.sites} sites x {config.followers}, WAN 50 Mbit/s and "
          f"20 ms one way, {duration:g} s windows: the cloud's mean AoI by K")
    for k, aoi in hierarchy.items():
        print(f"  K = {k!s:>4}: {aoi * 1e3:6.1f} ms")
    best = min(aoi for k, aoi in hierarchy.items() if k != "auto")
    print(f"  auto / best hand-set K: {hierarchy['auto'] / best:.2f} (target <= 1.10)")


def testbed(duration: float, rounds: int) -> None:
    print(f"\ntestbed, 20 Mbit/s tbf, N = 8, {rounds} x {duration:g} s each (K = 1, auto, "
          "alternating): mean AoI")
    aoi: dict[InFlight, list[float]] = {1: [], "auto": []}
    with tempfile.TemporaryDirectory() as tmp, Channel(ChannelSpec()) as channel:
        for round_ in range(rounds):
            for k in aoi:
                workdir = Path(tmp) / f"{round_}-{k}"
                workdir.mkdir()
                outcome = measure(channel, RunSpec("wiswarm", 8, in_flight=k,
                                                   duration=duration, warmup=4.0), workdir)
                aoi[k].append(mean(f.mean_aoi_s for f in outcome.result.followers))
    for k, values in aoi.items():
        print(f"  K = {k!s:>4}: {mean(values) * 1e3:6.1f} ms  "
              f"({', '.join(f'{v * 1e3:.1f}' for v in values)})")
    print(f"  auto / K = 1: {mean(aoi['auto']) / mean(aoi[1]):.3f} (target <= 1.05)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=["edge-cloud", "testbed"],
                        choices=["edge-cloud", "testbed"])
    parser.add_argument("--duration", type=float, default=15.0, help="seconds per window")
    parser.add_argument("--rounds", type=int, default=2, help="testbed: runs per K")
    args = parser.parse_args()
    try:
        check_available()
    except TestbedUnavailable as exc:
        print(f"bench_in_flight: {exc}")
        return 2
    if "edge-cloud" in args.cases:
        edge_cloud(args.duration)
    if "testbed" in args.cases:
        testbed(args.duration, args.rounds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
