"""What closing the edge-cloud experiment costs: open against ``--secure``, in paired
rounds (Linux, root).

Each round runs the experiment open and closed, one after the other (which goes first
alternates), with the same sites, followers, WAN and K polls in flight. A round's ratios
are closed / open of the hierarchy's mean AoI at the cloud, of the WAN it used each way,
and of the WAN bytes up per update delivered to the cloud (what TLS adds to each); the
edges alone give the sites' own AoI. Each figure is the median ratio over the rounds,
quartiles in brackets. Target: the closed mean AoI within 15 % of the open one's.

    .venv/bin/python benchmarks/bench_edge_cloud_secure.py --rounds 6
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

from wiswarm_zenoh.experiments.edge_cloud_run import (
    EdgeCloudConfig,
    SetupResult,
    run_edge_cloud,
)

TARGET = 1.15
FIGURES = {  # name -> what it is
    "aoi": "mean AoI at the cloud (ms)",
    "up": "WAN up (Mbit/s)",
    "down": "WAN down (Mbit/s)",
    "per_update": "WAN up per update delivered (kB)",
    "edge": "edges alone: mean AoI at the edge (ms)",
}


def _figures(hierarchy: SetupResult, edge: SetupResult) -> dict[str, float]:
    delivered = sum(f.throughput_fps for f in hierarchy.measured)  # updates/s at the cloud
    return {"aoi": hierarchy.mean("mean_aoi_s") * 1e3, "up": hierarchy.wan_up_mbps,
            "down": hierarchy.wan_down_mbps,
            "per_update": hierarchy.wan_up_mbps * 1e6 / 8 / delivered / 1e3,
            "edge": edge.mean("mean_aoi_s") * 1e3}


def run(secure: bool, k: int, duration: float) -> dict[str, float]:
    config = EdgeCloudConfig(in_flight=(k,), duration=duration, secure=secure)
    with tempfile.TemporaryDirectory() as tmp:
        results = run_edge_cloud(config, Path(tmp), lambda done, total: None)
    failed = sum(r.failed for r in results.results)
    if results.interrupted or failed:
        raise SystemExit(f"{'closed' if secure else 'open'} run: interrupted or {failed} "
                         "processes failed")
    by_kind = {r.setup.kind: r for r in results.results}
    return _figures(by_kind["hierarchy"], by_kind["edge"])


def _quartiles(values: list[float]) -> str:
    if len(values) < 2:
        return ""
    q = statistics.quantiles(values, n=4)
    return f" ({q[0]:.2f} .. {q[2]:.2f})"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=6, help="paired rounds (default 6)")
    parser.add_argument("--in-flight", type=int, help="the cloud leader's K (default: the "
                        "K that keeps the WAN busy, 6 in the default setting)")
    parser.add_argument("--duration", type=float, default=15.0, help="seconds per window")
    args = parser.parse_args()
    k = args.in_flight or EdgeCloudConfig().wan_in_flight()
    print(f"edge-cloud, 2 sites x 6 followers, 20 Mbit/s channels, WAN 50 Mbit/s and 20 ms, "
          f"K = {k}, {args.duration:g} s windows; {args.rounds} rounds, open and closed")
    rows: dict[bool, list[dict[str, float]]] = {False: [], True: []}
    for round_ in range(args.rounds):
        for secure in (False, True) if round_ % 2 == 0 else (True, False):
            rows[secure].append(run(secure, k, args.duration))
        pair = [rows[s][-1] for s in (False, True)]
        print(f"  round {round_ + 1}: " + "; ".join(
            f"{name} {pair[0][name]:.2f} -> {pair[1][name]:.2f}" for name in FIGURES),
            flush=True)
    print("closed / open, median of the rounds (quartiles):")
    for name, what in FIGURES.items():
        opened = [r[name] for r in rows[False]]
        closed = [r[name] for r in rows[True]]
        ratios = [c / o for o, c in zip(opened, closed, strict=True) if o > 0]
        print(f"  {what}: open {statistics.median(opened):.2f}, closed "
              f"{statistics.median(closed):.2f}; closed / open "
              f"{statistics.median(ratios):.3f}{_quartiles(ratios)}")
    aoi = statistics.median(c["aoi"] / o["aoi"] for o, c in zip(rows[False], rows[True],
                                                                strict=True))
    print(f"target: closed mean AoI <= {TARGET:g} x open: "
          f"{'met' if aoi <= TARGET else 'not met'} ({aoi:.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
