"""Sources slower than the polls: the index on the age a poll can remove (``sources``)
against the paper's index (every source taken as always fresh), in the slotted model
and on real processes over the testbed's shared channel.

- slotted: N = 8, the first ``slow`` sources make an update every 20 or 50 slots, the
  others every slot; 5 seeds of 20,000 slots: the fast followers' weighted mean AoI,
  the slow ones', and the share of polls that found nothing new;
- testbed (Linux, root): 4 cameras at 100 Hz and 4 at 5 Hz over a 20 Mbit/s tbf channel
  (49 kB frames): polls that found nothing new (target <= 10 % of all polls) and the
  100 Hz followers' mean AoI with both indices (target: better than the paper's).

    .venv/bin/python benchmarks/bench_sources.py
    .venv/bin/python benchmarks/bench_sources.py --cases slotted
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path
from statistics import mean

from wiswarm_zenoh.sim.arrivals import ArrivalResult, ArrivalSpec, run_arrivals
from wiswarm_zenoh.testbed import ChannelSpec, TestbedUnavailable, check_available
from wiswarm_zenoh.testbed.channel import Channel
from wiswarm_zenoh.testbed.run import RunOutcome, RunSpec, measure


def slotted(seeds: int) -> None:
    print("slotted model, N = 8, 5 seeds x 20,000 slots: paper's index -> paced index")
    print(f"{'slow':>5} {'every':>6} {'fast AoI (slots)':>22} {'slow AoI (slots)':>22} "
          f"{'polls finding nothing':>26}")
    for slow, interval in ((0, 20.0), (2, 20.0), (4, 20.0), (4, 50.0), (6, 20.0)):
        cells: list[tuple[ArrivalResult, ArrivalResult]] = []
        for seed in range(seeds):
            spec = ArrivalSpec(slow=slow, slow_interval=interval, paced=False, seed=seed)
            cells.append((run_arrivals(spec), run_arrivals(dataclasses.replace(spec,
                                                                                paced=True))))

        def pair(attr: str, cells: list[tuple[ArrivalResult, ArrivalResult]] = cells) -> str:
            a = mean(getattr(c[0], attr) for c in cells)
            b = mean(getattr(c[1], attr) for c in cells)
            return f"{a:7.1f} -> {b:6.1f}" if attr != "empty_share" else \
                f"{a:8.1%} -> {b:6.1%}"

        print(f"{slow:5d} {interval:6.0f} {pair('fast_aoi'):>22} "
              f"{pair('slow_aoi') if slow else '-':>22} {pair('empty_share'):>26}")


def _run(channel: Channel, paced: bool, duration: float, workdir: Path) -> RunOutcome:
    spec = RunSpec("wiswarm", 8, slow=4, slow_rate=5.0, pace_sources=paced,
                   duration=duration, warmup=4.0)
    return measure(channel, spec, workdir)


def testbed(duration: float, rounds: int) -> None:
    try:
        check_available()
    except TestbedUnavailable as exc:
        print(f"\ntestbed: skipped ({exc})")
        return
    print(f"\ntestbed, 20 Mbit/s tbf, 4 cameras at 100 Hz + 4 at 5 Hz, {rounds} x "
          f"{duration:g} s each (paper's index, paced, alternating):")
    results: dict[bool, list[RunOutcome]] = {False: [], True: []}
    with tempfile.TemporaryDirectory() as tmp, Channel(ChannelSpec()) as channel:
        for k in range(rounds):
            for paced in (False, True):
                workdir = Path(tmp) / f"{k}-{paced}"
                workdir.mkdir()
                results[paced].append(_run(channel, paced, duration, workdir))
    for paced, outcomes in results.items():
        fast = mean(f.mean_aoi_s for o in outcomes for f in o.result.followers[:4])
        slow = mean(f.mean_aoi_s for o in outcomes for f in o.result.followers[4:])
        polls = sum(o.result.channel.get("polls", 0.0) for o in outcomes)
        empty = sum(o.result.channel.get("empty_polls", 0.0) for o in outcomes)
        name = "paced index " if paced else "paper's index"
        print(f"  {name}: 100 Hz mean AoI "
              f"{fast * 1e3:6.1f} ms, 5 Hz {slow * 1e3:6.1f} ms, polls finding nothing "
              f"{empty / max(polls, 1):6.1%} of {polls:.0f}")
    print("  targets: polls finding nothing <= 10 %; 100 Hz AoI better than the paper's")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=["slotted", "testbed"],
                        choices=["slotted", "testbed"])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--duration", type=float, default=12.0, help="testbed: s per run")
    parser.add_argument("--rounds", type=int, default=2, help="testbed: runs per index")
    args = parser.parse_args()
    if "slotted" in args.cases:
        slotted(args.seeds)
    if "testbed" in args.cases:
        testbed(args.duration, args.rounds)


if __name__ == "__main__":
    main()
