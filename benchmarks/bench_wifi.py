"""WiSwarm against the push baselines on real processes over ns-3's 802.11 (the WiFi medium).

First, which N this machine holds in real time: for each N, WiSwarm and push-block at
50 fps (the heaviest load: every station saturates the air) over the medium, each run's
largest lag of the simulation behind the wall clock against the hard limit, with the load
average seen. Then, at the largest N held, the stationary study (WiSwarm, every baseline
at 50 fps and at its best rate): WiSwarm's mean AoI against the round-robin floor S (N/2
+ 1), S measured on the medium (the window over the polls that delivered), the gains
table beside the paper's, and the air's counters per run. Linux, root, ns-3.

    .venv/bin/python benchmarks/bench_wifi.py
    .venv/bin/python benchmarks/bench_wifi.py --ns 4,8,14 --duration 15
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

from study_flags import parse_on_testbed, study_parser

from wiswarm_zenoh.experiments.sweep_report import gains_table
from wiswarm_zenoh.experiments.testbed_study import StudyConfig, run_study
from wiswarm_zenoh.experiments.testbed_study_report import floor_lines, medium_lines, summarise
from wiswarm_zenoh.options import ProgressBar, add_wifi_arguments, wifi_of
from wiswarm_zenoh.testbed.ns3_build import unavailable_reason
from wiswarm_zenoh.testbed.run import RunSpec, measure
from wiswarm_zenoh.testbed.wifi import WifiMedium
from wiswarm_zenoh.testbed.wifi_spec import MediumFailed, WifiSpec

LOADS = (("wiswarm", 100.0), ("push-block", 50.0))


def held(n: int, spec: WifiSpec, duration: float, warmup: float) -> bool:
    """Whether the medium keeps real time at N under each load; prints each run."""
    ok = True
    with WifiMedium(WifiSpec(n, spec.standard, spec.data_mode, spec.hard_limit_ms)) as medium, \
            tempfile.TemporaryDirectory() as tmp:
        for system, rate in LOADS:
            load = os.getloadavg()[0]
            try:
                outcome = measure(medium, RunSpec(system, n, rate=rate, duration=duration,
                                                  warmup=warmup), Path(tmp))
            except MediumFailed as exc:
                print(f"  N={n:2d} {system}@{rate:g}: NOT HELD ({exc}); load {load:.1f}")
                return False
            air = outcome.result.channel
            print(f"  N={n:2d} {system}@{rate:g}: largest lag {air['max_lag_ms']:6.1f} ms "
                  f"(limit {spec.hard_limit_ms:g}), airtime {air['airtime_share']:.2f}, "
                  f"load average {load:.1f} before the run")
            ok = ok and air["max_lag_ms"] < spec.hard_limit_ms
    return ok


def main() -> int:
    parser = study_parser(__file__, __doc__, ns=(4, 8, 14))
    add_wifi_arguments(parser)
    parser.add_argument("--skip-limits", action="store_true",
                        help="study the largest N given without checking each first")
    args = parse_on_testbed(parser)
    if (reason := unavailable_reason()) is not None:
        print(f"bench_wifi: {reason}", file=sys.stderr)
        return 2
    spec = wifi_of(args, max(args.ns))
    print(f"real time on this machine ({os.cpu_count()} cores), {spec.describe()}:")
    reached = max(args.ns) if args.skip_limits else 0
    for n in ([] if args.skip_limits else sorted(args.ns)):
        if not held(n, spec, args.duration, args.warmup):
            break
        reached = n
    if not reached:
        print("no N held in real time")
        return 1
    print(f"\nlargest N held: {reached}; the study at N = {reached}:")
    config = StudyConfig(ns=(reached,), baselines=args.baselines,
                         duration=args.duration, warmup=args.warmup, medium=spec)
    with tempfile.TemporaryDirectory() as tmp:
        results = run_study(config, Path(tmp), ProgressBar("bench_wifi"))
    points = summarise(config, results)
    print("\n".join(floor_lines(results)))
    print("\ntarget: WiSwarm mean AoI <= 1.15 x floor\n")
    print(gains_table(points, config.fixed_rate, [reached], config.baselines))
    print("paper at N = 14: 109x (UDP) and 48x (TCP) against 50 fps; 2.2x against the best "
          "rate\n")
    print("\n".join(medium_lines(results)))
    return 130 if results.interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
