"""WiSwarm's mean AoI with 30 Hz cameras against the round-robin floor (issue 41, part
4: the age a camera's freshest frame already has when the poll reaches it, in whom to
poll and when), on the simulated tbf link (``sim``) or the testbed's (``testbed``: root,
the ROS 2 air benchmark's case (c), about 40 s a run).

The simulator's cameras are offered to their follower lazily, one frame per poll, so
their sequence numbers count the frames taken rather than the frames made, and no
leader can learn a camera's interval from them. ``sim`` offers each camera's follower
every frame it makes, as a real camera's is (a ROS 2 topic's subscriber takes every
message): the frames a poll skipped are offered, each replacing the one before in the
LIFO, before the freshest. ``--lazy`` runs the simulator as it is.

    .venv/bin/python benchmarks/bench_index_phase.py sim --ns 4,8,14 --seeds 10
    flock /tmp/bench.lock .venv/bin/python benchmarks/bench_index_phase.py testbed --reps 3

Another tree's core (the index before a change, say) is measured from that tree, whose
modules every process the run starts then imports:

    cd /tmp/idx-before && PYTHONPATH=$PWD /work/main/.venv/bin/python \\
        /work/main/benchmarks/bench_index_phase.py testbed
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
from pathlib import Path
from unittest import mock

from wiswarm_zenoh.core.leader import PollRequest
from wiswarm_zenoh.sim import scenario
from wiswarm_zenoh.sim.link import LinkParams, LinkScenario, round_robin_floor, run_link
from wiswarm_zenoh.sim.wiswarm import STAMP, WiswarmNetwork


class EveryFrameOffered(WiswarmNetwork):
    """The simulator's WiSwarm network with cameras whose every frame is offered."""

    def _answer(self, request: PollRequest, received_at: float) -> None:
        i = self._index[request.follower]
        phase, period, last = self._phases[i], self._period, self._last_sample[i]
        latest = phase + math.floor((self._engine.now - phase) / period) * period
        if math.isfinite(last):
            for k in range(1, round((latest - last) / period)):
                made = last + k * period
                self.followers[i].offer(STAMP.pack(made), made)  # replaced before sent
                self._last_sample[i] = made
        super()._answer(request, received_at)


def sim_mean_aoi(n: int, seed: int, args: argparse.Namespace) -> float:
    """One simulated run's mean AoI (s) over its followers, on ground truth."""
    s = LinkScenario(n=n, sample_rate=args.sample_rate, frame_bytes=args.frame_bytes,
                     duration=args.duration, seed=seed)
    network = WiswarmNetwork if args.lazy else EveryFrameOffered
    with mock.patch.object(scenario, "WiswarmNetwork", network):
        return run_link(s).mean("mean_aoi_s")


def sim(args: argparse.Namespace) -> None:
    print("| N | mean AoI (ms) | min..max over seeds | floor (ms) | / floor |")
    print("|---|---|---|---|---|")
    for n in (int(n) for n in args.ns.split(",")):
        runs = [sim_mean_aoi(n, seed, args) for seed in range(args.seeds)]
        floor = round_robin_floor(n, args.frame_bytes, LinkParams(),
                                  scenario.DEFAULT_HOST_DELAY)
        mean = statistics.fmean(runs)
        print(f"| {n} | {mean * 1e3:.1f} | {min(runs) * 1e3:.1f}..{max(runs) * 1e3:.1f} | "
              f"{floor * 1e3:.1f} | {mean / floor:.3f} |", flush=True)


def testbed(args: argparse.Namespace) -> None:
    """Case (c) of the ROS 2 air benchmark at N robots on a fresh tbf channel, ``reps``
    times: its mean AoI at the ground against S (N/2 + 1), S measured in the run."""
    from wiswarm_zenoh.experiments.ros2_air import AirCase, AirConfig, measure_case
    from wiswarm_zenoh.experiments.ros2_air_report import floor_s
    from wiswarm_zenoh.testbed import check_available
    from wiswarm_zenoh.testbed.channel import Channel

    check_available()
    config = AirConfig(ns=(args.n,), media=("tbf",), duration=args.duration)
    print("| run | mean AoI (ms) | S (ms) | floor (ms) | / floor |")
    print("|---|---|---|---|---|")
    ratios = []
    for rep in range(args.reps):
        with tempfile.TemporaryDirectory() as tmp, Channel(config.channel) as medium:
            run = measure_case(medium, "tbf", AirCase("wiswarm", args.n), config, Path(tmp))
        floor = floor_s(run)
        ratios.append(run.mean() / floor)
        print(f"| {rep + 1} | {run.mean() * 1e3:.1f} | {floor / (args.n / 2 + 1) * 1e3:.1f} "
              f"| {floor * 1e3:.1f} | {ratios[-1]:.3f} |", flush=True)
    print(f"mean / floor: {statistics.fmean(ratios):.3f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    where = parser.add_subparsers(dest="where", required=True)
    on_sim = where.add_parser("sim", help="the simulated tbf link")
    on_sim.add_argument("--ns", default="4,8,14", help="followers per run, comma-separated")
    on_sim.add_argument("--seeds", type=int, default=10, help="runs per N (seeds 0, 1, ...)")
    on_sim.add_argument("--duration", type=float, default=120.0, help="simulated seconds")
    on_sim.add_argument("--sample-rate", type=float, default=30.0, help="cameras, fps")
    on_sim.add_argument("--frame-bytes", type=int, default=50_000)
    on_sim.add_argument("--lazy", action="store_true",
                        help="one frame offered per poll (the simulator as it is)")
    on_testbed = where.add_parser("testbed", help="the testbed's tbf channel (root)")
    on_testbed.add_argument("--n", type=int, default=4, help="robots")
    on_testbed.add_argument("--reps", type=int, default=3, help="runs")
    on_testbed.add_argument("--duration", type=float, default=20.0, help="window (s)")
    args = parser.parse_args()
    sim(args) if args.where == "sim" else testbed(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
