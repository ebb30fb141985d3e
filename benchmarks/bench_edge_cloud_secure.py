"""What closing the edge-cloud experiment costs: open against ``--secure``, in paired
rounds (Linux, root).

Each round runs the experiment open and closed, one after the other (which goes first
alternates), with the same sites, followers, WAN and K polls in flight. A round's ratios
are closed / open of the hierarchy's mean AoI at the cloud, of the WAN it used each way,
and of the WAN bytes up per update delivered to the cloud (what TLS adds to each); the
edges alone give the sites' own AoI. Each figure is the median ratio over the rounds,
quartiles in brackets. Target: the closed mean AoI within 15 % of the open one's.

    .venv/bin/python benchmarks/bench_edge_cloud_secure.py --rounds 6

With ``--against DIR`` (a ``git worktree`` of an older commit) each round runs closed
twice instead, this tree's code and DIR's, each in a process of its own: what a change
to the closed deployment cost (issue 43's per-site control and revocable passwords:
its target, this tree's mean AoI within 5 % of the older one's).

    git worktree add --detach /tmp/before 9cb5031
    .venv/bin/python benchmarks/bench_edge_cloud_secure.py --rounds 4 --against /tmp/before
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
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


def run_in_tree(tree: Path, k: int, duration: float) -> dict[str, float]:
    """A closed run of the code in ``tree`` (its own ``run``), in a process of its own."""
    code = ("import json, sys; sys.path[:0] = ['.', 'benchmarks']; "
            "from bench_edge_cloud_secure import run; "
            f"print(json.dumps(run(True, {k}, {duration})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=tree, check=True,
                         capture_output=True, text=True).stdout
    figures: dict[str, float] = json.loads(out.strip().splitlines()[-1])
    return figures


def _against(tree: Path, k: int, duration: float, rounds: int) -> None:
    """Closed runs of this tree and of ``tree``, alternating which goes first."""
    here = Path(__file__).resolve().parent.parent
    rows: dict[Path, list[dict[str, float]]] = {here: [], tree: []}
    for round_ in range(rounds):
        for side in (tree, here) if round_ % 2 == 0 else (here, tree):
            rows[side].append(run_in_tree(side, k, duration))
        print(f"  round {round_ + 1}: " + "; ".join(
            f"{name} {rows[tree][-1][name]:.2f} -> {rows[here][-1][name]:.2f}"
            for name in FIGURES), flush=True)
    print(f"closed, this tree / {tree}, median of the rounds (quartiles):")
    for name, what in FIGURES.items():
        ratios = [h[name] / t[name] for t, h in zip(rows[tree], rows[here], strict=True)
                  if t[name] > 0]
        print(f"  {what}: {statistics.median(r[name] for r in rows[tree]):.2f} -> "
              f"{statistics.median(r[name] for r in rows[here]):.2f}; "
              f"{statistics.median(ratios):.3f}{_quartiles(ratios)}")


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
    parser.add_argument("--against", type=Path, metavar="DIR", help="closed runs of this "
                        "tree against those of the tree at DIR (an older commit's worktree)")
    args = parser.parse_args()
    k = args.in_flight or EdgeCloudConfig().wan_in_flight()
    if args.against is not None:
        print(f"edge-cloud closed, this tree against {args.against}, K = {k}, "
              f"{args.duration:g} s windows; {args.rounds} rounds")
        _against(args.against.resolve(), k, args.duration, args.rounds)
        return 0
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
