"""WiSwarm against the push baselines on real processes over the emulated channel.

At N = 8 and N = 14 over a 20 Mbit/s tbf channel with 224x224 frames (Linux, root):
WiSwarm's mean AoI against the round-robin floor S (N/2 + 1), S measured on the channel
(the window over the polls that delivered), and the mean AoI, p95 AoI and throughput
ratios of every baseline, at 50 fps and at its best rate (the study's fine search from
the channel's share), to WiSwarm's, next to the paper's. All systems are measured in
the same run, on channels built alike. About 8 minutes with the defaults.

    .venv/bin/python benchmarks/bench_testbed.py
    .venv/bin/python benchmarks/bench_testbed.py --ns 8 --duration 20 --parallel 1
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from study_flags import parse_on_testbed, study_parser

from wiswarm_zenoh.experiments.sweep_report import gains_table
from wiswarm_zenoh.experiments.testbed_study import StudyConfig, run_study
from wiswarm_zenoh.experiments.testbed_study_report import floor_lines, summarise
from wiswarm_zenoh.options import ProgressBar
from wiswarm_zenoh.testbed import ChannelSpec
from wiswarm_zenoh.units import parse_rate


def main() -> int:
    parser = study_parser(__file__, __doc__, ns=(8, 14))
    parser.add_argument("--rate", type=parse_rate, default=20_000_000)
    parser.add_argument("--parallel", type=int, default=2)
    args = parse_on_testbed(parser)
    config = StudyConfig(ns=args.ns, baselines=args.baselines,
                         duration=args.duration, warmup=args.warmup,
                         channel=ChannelSpec(rate_bps=args.rate), parallel=args.parallel)
    with tempfile.TemporaryDirectory() as tmp:
        results = run_study(config, Path(tmp), ProgressBar("bench_testbed"))
    points = summarise(config, results)
    print("\n".join(floor_lines(results)))
    print("\ntarget: WiSwarm mean AoI <= 1.10 x floor at N = 8 and 14\n")
    print(gains_table(points, config.fixed_rate, args.ns, config.baselines))
    print("targets at N = 14: >= 109x (UDP) and 48x (TCP) against 50 fps; >= 2.2x "
          "against the best rate")
    print("\nchannel per run (uplink Mbit/s, tail drops, mean backlog kB):")
    for outcome in sorted(results.outcomes, key=lambda o: (o.result.n, o.result.system)):
        r = outcome.result
        label = r.system if r.rate is None else f"{r.system}@{r.rate:g}"
        c = r.channel
        print(f"  N={r.n:2d} {label:>16}: {c['uplink_mbps']:5.1f} Mbit/s, "
              f"{c['uplink_drops']:6.0f} drops, {c['uplink_backlog_kb']:6.0f} kB queued, "
              f"mean AoI {r.mean('mean_aoi_s'):7.3f} s")
    return 130 if results.interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
