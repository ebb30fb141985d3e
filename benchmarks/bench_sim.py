"""Simulator speed: simulated seconds per wall-clock second over the ``wifi`` channel.

Target (issue 4): 4 simulated minutes of WiSwarm at N = 14 in under 10 s of wall time.
Run: ``.venv/bin/python benchmarks/bench_sim.py`` (add ``--quick`` for shorter runs).
"""

from __future__ import annotations

import argparse
import time

from wiswarm_zenoh.sim.scenario import WifiScenario, run_wifi

TARGET_WALL_S = 10.0


def measure(n: int, system: str, duration: float) -> tuple[float, float, float]:
    """(wall seconds, simulated s per wall s, medium transmissions per wall s)."""
    started = time.perf_counter()
    result = run_wifi(WifiScenario(n=n, system=system, rate=50.0, duration=duration, seed=1))
    wall = time.perf_counter() - started
    return wall, duration / wall, result.channel["transmissions"] / wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="a quarter of the durations")
    args = parser.parse_args()
    scale = 0.25 if args.quick else 1.0
    cases = [(14, 240.0), (1000, 60.0)]
    header = ("N", "system", "sim s", "wall s", "sim s/wall s", "tx/wall s")
    print("{:>5} {:>8} {:>7} {:>7} {:>13} {:>10}".format(*header))
    for n, duration in cases:
        for system in ("wiswarm", "udp", "tcp"):
            wall, speed, tx_rate = measure(n, system, duration * scale)
            print(f"{n:5d} {system:>8} {duration * scale:7.0f} {wall:7.2f} {speed:13.1f} "
                  f"{tx_rate:10.0f}")
    wall, _, _ = measure(14, "wiswarm", 240.0)
    verdict = "meets" if wall < TARGET_WALL_S else "MISSES"
    print(f"WiSwarm N=14, 240 simulated s: {wall:.2f} s wall "
          f"({verdict} the {TARGET_WALL_S:g} s target)")


if __name__ == "__main__":
    main()
