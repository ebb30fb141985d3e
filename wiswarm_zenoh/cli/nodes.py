"""``wiswarm router | leader | follower | swarm-demo``: the middleware's processes.

``--system push|udp|tcp`` turns a follower into a baseline a Zenoh user would pick
instead of polling (frames pushed at a fixed rate) and a leader into its receiver,
which publishes the same stats as the polling leader.

Zenoh flags follow zenoh-python's examples (-m/-e/-l/-c/--cfg/--no-multicast-scouting).
Without -e or -c, leader and follower connect to a router on this machine
(``wiswarm router``, tcp/127.0.0.1:7447) as peers.
"""

from __future__ import annotations

import argparse
import sys
import threading
from typing import Any

from wiswarm_zenoh.baselines import (
    BaselineFollowerOptions,
    Receiver,
    ReceiverOptions,
    run_baseline_followers,
    run_receiver,
)
from wiswarm_zenoh.baselines.runners import DEFAULT_BIND
from wiswarm_zenoh.baselines.senders import CONGESTION, DEFAULT_CAPACITY, parse_address
from wiswarm_zenoh.baselines.stamp import HEADER_BYTES, MAX_UDP_PAYLOAD
from wiswarm_zenoh.cli.usage import UsageError
from wiswarm_zenoh.core import POLICIES, FollowerConfig, LeaderConfig
from wiswarm_zenoh.transport.demo import DemoOptions, run_demo
from wiswarm_zenoh.transport.frames import FRAME_BYTES, FRAME_HEADER_BYTES, FRAME_RATE
from wiswarm_zenoh.transport.keys import SwarmKeys, check_follower
from wiswarm_zenoh.transport.leader_node import CONTROL_PERIOD, LeaderNode
from wiswarm_zenoh.transport.report import LiveTable, PollRates, format_table
from wiswarm_zenoh.transport.runners import (
    FollowerOptions,
    LeaderOptions,
    run_follower,
    run_leader,
    run_router,
)
from wiswarm_zenoh.transport.ticker import MAX_RATE_HZ
from wiswarm_zenoh.transport.zenoh_config import (
    LOCAL_ROUTER,
    MODES,
    SessionSpec,
    add_zenoh_arguments,
)

DEFAULT_SWARM = "swarm"
SYSTEMS = ("wiswarm", "push", "udp", "tcp")
BASELINE_RATE = 50.0  # the paper's fixed-rate baselines


def _positive(kind: type[float] | type[int], most: float = float("inf")) -> Any:
    def parse(text: str) -> float | int:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not 0 < value <= most:
            raise argparse.ArgumentTypeError(f"must be in (0, {most:g}], got {text}")
        return value

    return parse


def _add_common(parser: argparse.ArgumentParser, modes: tuple[str, ...]) -> None:
    add_zenoh_arguments(parser, modes)
    parser.add_argument("--duration", type=_positive(float), metavar="SECONDS",
                        help="stop after this long (default: until Ctrl-C)")


def _add_swarm(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--swarm", default=DEFAULT_SWARM, help="swarm name (a key chunk)")


def _checked(build: Any, *args: Any, **kwargs: Any) -> Any:
    """Build a config object; its ValueError (naming the field) is the user's to fix."""
    try:
        return build(*args, **kwargs)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _spec(args: argparse.Namespace, default_mode: str) -> SessionSpec:
    spec = SessionSpec.from_args(args, default_mode,
                                 () if default_mode == "router" else (LOCAL_ROUTER,))
    spec.config()  # every flag checked before anything starts
    return spec


class _Announce:
    """A ready signal that tells the user the node is up."""

    def __init__(self, text: str) -> None:
        self._text = text

    def set(self) -> None:
        print(self._text, flush=True)


def _router(args: argparse.Namespace) -> int:
    spec = _spec(args, "router")
    where = ", ".join(spec.listen) or "tcp/[::]:7447"
    run_router(spec, threading.Event(),
               _Announce(f"wiswarm router: listening on {where} (Ctrl-C to stop)"), args.duration)
    return 0


def _receiver(args: argparse.Namespace) -> int:
    """``wiswarm leader --system push|udp|tcp``: a baseline's receiver."""
    options = ReceiverOptions(args.swarm, args.system, args.bind, args.record, args.duration)
    if args.system != "push":
        _checked(parse_address, args.bind)
    spec = _spec(args, "peer")
    table, title = LiveTable(), f"wiswarm leader: swarm {args.swarm!r}, {args.system} receiver"

    def show(receiver: Receiver) -> None:
        rates = {str(r["follower"]): float(r["deliveries_per_s"]) for r in receiver.latest}
        table.show(format_table(receiver.latest, rates, f"{title}, deliveries/s in the "
                                f"polls/s column, up {receiver.summary.uptime_s:.0f} s"))

    try:
        receiver = run_receiver(spec, options, threading.Event(), _Announce(
            f"{title}: waiting for frames (Ctrl-C to stop)"), show)
    except OSError as exc:  # the address is taken or not ours
        raise UsageError(f"cannot listen on {args.bind}: {exc.strerror or exc}") from None
    print("\n".join(["", "summary", *format_table(receiver.latest, {}, title)]))
    return 0


def _leader(args: argparse.Namespace) -> int:
    _checked(SwarmKeys, args.swarm)
    if args.system != "wiswarm":
        return _receiver(args)
    config = _checked(LeaderConfig, policy=args.policy, timeout=args.timeout,
                      window=args.window, alpha=args.alpha)
    if args.control_period < 0:
        raise UsageError(f"--control-period must be >= 0, got {args.control_period}")
    options = LeaderOptions(args.swarm, config, args.duration, args.control_period, args.record)
    spec = _spec(args, "peer")
    table, rates = LiveTable(), PollRates()
    title = f"wiswarm leader: swarm {args.swarm!r}, policy {config.policy}"

    def show(node: LeaderNode) -> None:
        summary = node.summary
        for record in node.latest:
            rates.observe(str(record["follower"]), float(record["polls"]), summary.uptime_s)
        header = f"{title}, {summary.polls_per_s:.0f} polls/s, up {summary.uptime_s:.0f} s"
        table.show(format_table(node.latest, rates.rates, header))

    node = run_leader(spec, options, threading.Event(),
                      _Announce(f"{title}: waiting for followers (Ctrl-C to stop)"), show)
    print("\n".join(["", "summary", *format_table(node.latest, rates.rates, title)]))
    return 0


def _baseline_follower(args: argparse.Namespace) -> int:
    """``wiswarm follower --system push|udp|tcp``: frames pushed at ``--rate``."""
    rate = args.rate or BASELINE_RATE
    limit = MAX_UDP_PAYLOAD - HEADER_BYTES - len(args.id.encode())
    if args.system == "udp" and args.frame_bytes > limit:
        raise UsageError(f"--frame-bytes {args.frame_bytes} does not fit one UDP datagram "
                         f"(at most {limit} with this id)")
    if args.to is not None:
        _checked(parse_address, args.to)
    options = _checked(BaselineFollowerOptions, args.swarm, (args.id,), args.system, rate,
                       args.congestion or "block", args.frame_bytes, args.to,
                       args.capacity or DEFAULT_CAPACITY, args.duration)
    spec = _spec(args, "peer")
    how = f"{args.congestion or 'block'} put" if args.system == "push" else f"to {args.to}"
    run_baseline_followers(spec, options, threading.Event(), _Announce(
        f"wiswarm follower {args.id}: {args.frame_bytes}-byte frames at {rate:g} Hz, "
        f"{args.system} ({how}) (Ctrl-C to stop)"))
    return 0


def _follower(args: argparse.Namespace) -> int:
    _checked(check_follower, args.id)
    _checked(SwarmKeys, args.swarm)
    if args.system == "wiswarm":
        for flag, value in (("--congestion", args.congestion), ("--to", args.to)):
            if value is not None:
                raise UsageError(f"{flag} is for --system push/udp/tcp, not wiswarm")
    else:
        if args.congestion is not None and args.system != "push":
            raise UsageError(f"--congestion is for --system push, not {args.system}")
        if args.system != "push" and args.to is None:
            raise UsageError(f"--system {args.system} needs --to HOST:PORT (the receiver, "
                             "wiswarm leader --system " + args.system + ")")
        _check_frame_bytes(args.frame_bytes, FollowerConfig())
        return _baseline_follower(args)
    args.rate = args.rate or FRAME_RATE
    args.capacity = args.capacity or 1
    config = _checked(FollowerConfig, queue=args.queue, capacity=args.capacity,
                      rate_hz=args.rate if args.queue == "fifo" else None,
                      fragment_size=args.fragment_size)
    _check_frame_bytes(args.frame_bytes, config)
    options = FollowerOptions(args.swarm, args.id, config, args.frame_bytes, args.rate,
                              args.duration)
    spec = _spec(args, "peer")
    run_follower(spec, options, threading.Event(), _Announce(
        f"wiswarm follower {args.id}: {args.frame_bytes}-byte frames at {args.rate:g} Hz, "
        f"{args.queue} queue (Ctrl-C to stop)"))
    return 0


def _check_frame_bytes(frame_bytes: int, config: FollowerConfig) -> None:
    if not FRAME_HEADER_BYTES <= frame_bytes <= config.max_update_bytes:
        raise UsageError(f"--frame-bytes must be in [{FRAME_HEADER_BYTES}, "
                         f"{config.max_update_bytes}], got {frame_bytes}")


def _demo(args: argparse.Namespace) -> int:
    _check_frame_bytes(args.frame_bytes, FollowerConfig())
    run_dir = run_demo(DemoOptions(args.followers, args.duration, args.policy,
                                   args.frame_bytes, args.rate, args.out))
    print(f"run directory: {run_dir}", file=sys.stdout)
    return 0


def register(subparsers: Any) -> None:
    router = subparsers.add_parser("router", help="a Zenoh router (default: tcp/[::]:7447)")
    _add_common(router, MODES)
    router.set_defaults(func=_router)

    leader = subparsers.add_parser("leader", help="poll the followers of a swarm (or receive "
                                   "a push baseline's frames)")
    _add_swarm(leader)
    leader.add_argument("--system", choices=SYSTEMS, default="wiswarm",
                        help="wiswarm: poll (default); push|udp|tcp: receive a baseline's "
                        "frames and publish the same stats")
    leader.add_argument("--bind", default=DEFAULT_BIND, metavar="HOST:PORT",
                        help=f"udp/tcp receivers listen here (default {DEFAULT_BIND})")
    leader.add_argument("--policy", default="whittle", choices=sorted(POLICIES))
    leader.add_argument("--timeout", type=_positive(float), default=0.3,
                        help="seconds to wait for a reply (default 0.3)")
    leader.add_argument("--window", type=_positive(int), default=20,
                        help="polls over which each follower's reliability is estimated")
    leader.add_argument("--alpha", type=float, default=0.8, help="weight EMA factor in [0, 1]")
    leader.add_argument("--control-period", type=float, default=CONTROL_PERIOD,
                        metavar="SECONDS", help="repeat unchanged control information this "
                        f"often (default {CONTROL_PERIOD}); 0 puts it with every poll")
    leader.add_argument("--record", metavar="CSV", help="write every delivery to this file")
    _add_common(leader, ("peer", "client"))
    leader.set_defaults(func=_leader)

    follower = subparsers.add_parser("follower", help="a follower sending synthetic frames")
    _add_swarm(follower)
    follower.add_argument("--id", required=True, help="this follower's id (a key chunk)")
    follower.add_argument("--system", choices=SYSTEMS, default="wiswarm",
                          help="wiswarm: answer polls (default); push: put every frame on "
                          "wiswarm/<swarm>/<id>/push; udp/tcp: send every frame to --to")
    follower.add_argument("--congestion", choices=sorted(CONGESTION),
                          help="push: block (reliable, the put waits; default) or drop "
                          "(Zenoh's default for put)")
    follower.add_argument("--to", metavar="HOST:PORT",
                          help="udp/tcp: the receiver (wiswarm leader --system udp|tcp)")
    follower.add_argument("--queue", choices=["lifo", "fifo"], default="lifo")
    follower.add_argument("--capacity", type=_positive(int),
                          help=f"queue capacity (default 1; push/udp/tcp: a FIFO of "
                          f"{DEFAULT_CAPACITY})")
    follower.add_argument("--rate", type=_positive(float, MAX_RATE_HZ),
                          help=f"frames per second (default {FRAME_RATE:g}; push/udp/tcp "
                          f"{BASELINE_RATE:g}) and the FIFO's rate control")
    follower.add_argument("--fragment-size", type=_positive(int), default=65536,
                          help="bytes per reply (default 65536)")
    follower.add_argument("--frame-bytes", type=_positive(int), default=FRAME_BYTES,
                          help=f"bytes per synthetic frame (default {FRAME_BYTES} = 224x224)")
    _add_common(follower, ("peer", "client"))
    follower.set_defaults(func=_follower)

    demo = subparsers.add_parser(
        "swarm-demo", help="router + leader + synthetic followers, live table and plots"
    )
    demo.add_argument("--followers", type=_positive(int), default=6)
    demo.add_argument("--duration", type=_positive(float), default=20.0, metavar="SECONDS")
    demo.add_argument("--policy", default="whittle", choices=sorted(POLICIES))
    demo.add_argument("--frame-bytes", type=_positive(int), default=FRAME_BYTES)
    demo.add_argument("--rate", type=_positive(float, MAX_RATE_HZ), default=FRAME_RATE,
                      help="frames/s")
    demo.add_argument("--out", default="runs", help="where run directories go")
    demo.set_defaults(func=_demo)
