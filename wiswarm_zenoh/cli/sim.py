"""``wiswarm sim slotted|wifi|link`` and ``wiswarm experiment sweep``: the simulator's CLI."""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

from wiswarm_zenoh.core.policies import POLICIES
from wiswarm_zenoh.dashboard.live_points import add_live_arguments, open_live, sweep_by_n
from wiswarm_zenoh.experiments.sweep import BASELINES as SWEEP_BASELINES
from wiswarm_zenoh.experiments.sweep import (
    PAPER_NS,
    PAPER_RATES,
    SweepConfig,
    run_sweep,
    summarise,
)
from wiswarm_zenoh.experiments.sweep_report import write_report
from wiswarm_zenoh.options import (
    COUNTS,
    PROBABILITIES,
    RATE,
    SEED,
    TIME,
    OneLineParser,
    ProgressBar,
    UsageError,
    add_rate_grid,
    float_range,
    positive_float,
    positive_int,
    writable_dir,
)
from wiswarm_zenoh.sim.link import LinkParams, LinkScenario, run_link
from wiswarm_zenoh.sim.metrics import WifiResult
from wiswarm_zenoh.sim.scenario import (
    DEFAULT_RELIABILITY,
    NEWEST_SEND_BUFFER,
    PAPER_FRAME_BYTES,
    RATELESS_SYSTEMS,
    SYSTEMS,
    WifiScenario,
    run_wifi,
)
from wiswarm_zenoh.sim.slotted import DEFAULT_SLOTS, SlottedSpec, run_slotted
from wiswarm_zenoh.units import format_rate


def _build(factory: Any, **kwargs: Any) -> Any:
    """Construct a validated spec; its ValueError is the user's mistake."""
    try:
        return factory(**kwargs)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _print_json(obj: object) -> None:
    print(json.dumps(obj, indent=2))


def _slotted(args: argparse.Namespace) -> int:
    spec = _build(SlottedSpec, n=args.n, policy=args.policy, seed=args.seed,
                  weights=args.weights, reliability=args.reliability, slots=args.slots)
    result = run_slotted(spec)
    if args.json:
        _print_json(result.as_dict())
    else:
        print(f"{result.policy}: N={result.n} EWSAoI={result.ewsaoi:.3f} slots, "
              f"L_B={result.lower_bound:.3f}, ratio={result.ratio:.4f}")
    return 0


def _print_wifi(result: WifiResult) -> None:
    print(f"{result.system} N={result.n} over {result.duration:g} s:")
    print(f"{'follower':>10} {'mean AoI':>10} {'p95 AoI':>10} {'peak AoI':>10} {'fps':>8}")
    for f in result.followers:
        print(f"{f.follower:>10} {f.mean_aoi_s:10.4f} {f.p95_aoi_s:10.4f} "
              f"{f.peak_aoi_s:10.4f} {f.throughput_fps:8.2f}")
    print(f"{'mean':>10} {result.mean('mean_aoi_s'):10.4f} {result.mean('p95_aoi_s'):10.4f} "
          f"{result.mean('peak_aoi_s'):10.4f} {result.mean('throughput_fps'):8.2f}")
    print("channel: " + ", ".join(f"{k} {v:.6g}" for k, v in result.channel.items()))


def _workload(args: argparse.Namespace) -> dict[str, Any]:
    """The flags every channel's run takes (``_add_workload``), as scenario fields."""
    if args.system in RATELESS_SYSTEMS and args.rate is not None:
        raise UsageError(f"--rate is the push rate of udp and tcp; {args.system} samples at "
                         "--sample-rate")
    if args.system != "newest" and args.send_buffer is not None:
        raise UsageError("--send-buffer is newest's")
    return {
        "n": args.n, "system": args.system, "rate": 50.0 if args.rate is None else args.rate,
        "frame_bytes": args.frame_bytes, "duration": args.duration, "seed": args.seed,
        "fifo_frames": args.fifo_frames, "sample_rate": args.sample_rate,
        "policy": args.policy, "send_buffer": args.send_buffer or NEWEST_SEND_BUFFER,
    }


def _show(result: WifiResult, as_json: bool) -> int:
    if as_json:
        _print_json(result.as_dict())
    else:
        _print_wifi(result)
    return 0


def _wifi(args: argparse.Namespace) -> int:
    scenario = _build(WifiScenario, reliability=args.reliability, **_workload(args))
    return _show(run_wifi(scenario), args.json)


def _link(args: argparse.Namespace) -> int:
    link = _build(LinkParams, rate_bps=args.link_rate, down_rate_bps=args.down_rate,
                  queue_s=args.queue)
    scenario = _build(LinkScenario, link=link, **_workload(args))
    return _show(run_link(scenario), args.json)


def _sweep(args: argparse.Namespace) -> int:
    config = _build(
        SweepConfig, ns=args.ns, rates=args.rates or PAPER_RATES, search=args.search,
        fixed_rate=args.fixed_rate, batches=args.batches, duration=args.duration,
        seed=args.seed, frame_bytes=args.frame_bytes,
    )
    out = args.out or Path("runs") / time.strftime("sweep-%Y%m%d-%H%M%S")
    bar = ProgressBar("sweep")
    with open_live(args, out, "sweep", SWEEP_BASELINES, config.fixed_rate) as live:
        results = run_sweep(config, args.jobs, bar) if live is None else sweep_by_n(
            config, lambda part, progress: run_sweep(part, args.jobs, progress), bar, live)
    files = write_report(out, config, results, summarise(config, results))
    for path in files:
        print(path)
    print(files[-1].read_text(), end="")
    return 0


def _add_workload(parser: argparse.ArgumentParser) -> None:
    """The flags of a run over any channel: the system, its followers and cameras."""
    parser.add_argument("--n", type=positive_int(), required=True,
                        help="number of followers (UAVs)")
    parser.add_argument("--system", default="wiswarm", choices=SYSTEMS,
                        help="the system simulated (default wiswarm); newest: each "
                        "follower sends its camera's newest frame over TCP the moment its "
                        "previous send completed (no rate to tune)")
    parser.add_argument("--rate", type=positive_float(),
                        help="udp/tcp frames per second (default 50)")
    parser.add_argument("--frame-bytes", type=positive_int(), default=PAPER_FRAME_BYTES,
                        help=f"bytes per camera frame (default {PAPER_FRAME_BYTES})")
    parser.add_argument("--duration", type=positive_float(), default=240.0,
                        help="simulated seconds (default 240)")
    parser.add_argument("--seed", type=SEED, default=0, help="random seed (default 0)")
    parser.add_argument("--fifo-frames", type=positive_int(),
                        help="bound the baselines' FIFO (default unbounded)")
    parser.add_argument("--sample-rate", type=positive_float(), default=100.0,
                        help="WiSwarm's and newest's cameras, fps (default 100)")
    parser.add_argument("--send-buffer", type=positive_int(), metavar="BYTES",
                        help=f"newest: SO_SNDBUF (default {NEWEST_SEND_BUFFER}; the kernel "
                        "doubles it), small so that a frame waits in the slot, not in TCP")
    parser.add_argument("--policy", default="whittle", choices=sorted(POLICIES),
                        help="WiSwarm's scheduling policy (default whittle)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def register(subparsers: Any) -> None:
    """Add ``sim`` (slotted, wifi, link); ``experiment sweep`` is added by
    ``wiswarm_zenoh.cli.experiment`` through ``register_sweep``."""
    sim = subparsers.add_parser("sim", help="simulate polling over a shared channel")
    kinds = sim.add_subparsers(dest="channel", metavar="CHANNEL", parser_class=OneLineParser)
    kinds.required = True

    slotted = kinds.add_parser("slotted", help="Kadota et al.'s slotted model, against L_B")
    slotted.add_argument("--n", type=positive_int(), required=True, help="number of followers")
    slotted.add_argument("--policy", default="whittle", choices=sorted(POLICIES),
                         help="whom to poll next (default whittle)")
    slotted.add_argument("--seed", type=SEED, default=0, help="random seed (default 0)")
    slotted.add_argument("--weights", type=float_range(positive_float()), default=(1.0, 5.0),
                         metavar="LO:HI", help="weights drawn from U[LO, HI] (default 1:5)")
    slotted.add_argument("--reliability", type=PROBABILITIES, default=(0.5, 1.0),
                         metavar="LO:HI",
                         help="success probabilities from U[LO, HI] (default 0.5:1)")
    slotted.add_argument("--slots", type=positive_int(), default=DEFAULT_SLOTS,
                         help=f"slots to simulate (default {DEFAULT_SLOTS})")
    slotted.add_argument("--json", action="store_true", help="print one JSON object")
    slotted.set_defaults(func=_slotted)

    wifi = kinds.add_parser("wifi", help="an 802.11 shared medium with CSMA/CA")
    _add_workload(wifi)
    lo, hi = DEFAULT_RELIABILITY
    wifi.add_argument("--reliability", type=PROBABILITIES, default=DEFAULT_RELIABILITY,
                      metavar="LO:HI", help=f"per-attempt MAC success, U[LO, HI] ({lo}:{hi})")
    wifi.set_defaults(func=_wifi)

    defaults = LinkParams()
    link = kinds.add_parser("link", help="the testbed's link: a tc tbf each way over a veth")
    _add_workload(link)
    link.add_argument("--link-rate", default=defaults.rate_bps, metavar="RATE", type=RATE,
                      help="the uplink's (and by default the downlink's) tbf rate "
                           f"(default {format_rate(defaults.rate_bps)})")
    link.add_argument("--down-rate", metavar="RATE", type=RATE,
                      help="the downlink's rate, if different")
    link.add_argument("--queue", default=defaults.queue_s, metavar="TIME", type=TIME,
                      help=f"tbf latency: the queue's limit (default {defaults.queue_s * 1e3:g}ms)")
    link.set_defaults(func=_link)


def register_sweep(studies: Any) -> None:
    """``experiment sweep``: the stationary study in the simulator."""
    sweep = studies.add_parser("sweep", help="the stationary study: AoI against N and rate")
    sweep.add_argument("--ns", type=COUNTS, default=PAPER_NS,
                       help="numbers of UAVs (default 2,4,...,14)")
    add_rate_grid(sweep, "the baselines'", searched="rates every baseline runs at (the AoI against "
                  "rate figure; --search grid's choices)")
    sweep.add_argument("--batches", type=positive_int(), default=4,
                       help="batches per point (default 4)")
    sweep.add_argument("--duration", type=positive_float(), default=240.0,
                       help="seconds per batch (default 240)")
    sweep.add_argument("--seed", type=SEED, default=0, help="seed of the first batch")
    sweep.add_argument("--frame-bytes", type=positive_int(), default=PAPER_FRAME_BYTES,
                       help=f"bytes per camera frame (default {PAPER_FRAME_BYTES})")
    sweep.add_argument("--jobs", type=positive_int(), default=os.cpu_count() or 1,
                       help="parallel worker processes (default: one per core)")
    sweep.add_argument("--out", type=writable_dir(), metavar="DIR",
                       help="output directory (runs/sweep-<timestamp>)")
    add_live_arguments(sweep)
    sweep.set_defaults(func=_sweep, needs="plots")
