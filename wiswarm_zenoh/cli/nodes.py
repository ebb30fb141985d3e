"""``wiswarm router | leader | follower | swarm-demo``: the middleware's processes.

``--system push|udp|tcp`` turns a follower into a baseline a Zenoh user would pick
instead of polling (frames pushed at a fixed rate, or with ``--newest-only`` each
frame sent once the previous send completed) and a leader into its receiver, which
publishes the same stats as the polling leader.

Zenoh flags follow zenoh-python's examples (-m/-e/-l/-c/--cfg/--no-multicast-scouting).
Without -e or -c, leader and follower connect to a router on this machine
(``wiswarm router``, tcp/127.0.0.1:7447) as peers; given -e (and no -l), they are
clients of the router it names (``zenoh_config.ATTACHED_MODE`` says why).
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
from pathlib import Path
from typing import Any

from wiswarm_zenoh import Leader
from wiswarm_zenoh.baselines import (
    CONGESTION,
    DEFAULT_BIND,
    DEFAULT_CAPACITY,
    NEWEST_SEND_BUFFER,
    BaselineFollowerOptions,
    Receiver,
    ReceiverOptions,
    run_baseline_followers,
    run_receiver,
)
from wiswarm_zenoh.baselines import SYSTEMS as BASELINES
from wiswarm_zenoh.core import POLICIES, FollowerConfig, LeaderConfig
from wiswarm_zenoh.extras import require
from wiswarm_zenoh.options import (
    IN_FLIGHT,
    UsageError,
    add_ros2_arguments,
    add_source_arguments,
    add_zenoh_arguments,
    finite_float,
    host_port,
    node_name,
    positive_float,
    positive_int,
    ros2_options,
    source_of,
    writable_dir,
    writable_file,
)
from wiswarm_zenoh.programs.demo import DemoOptions, run_demo
from wiswarm_zenoh.programs.frames import FRAME_BYTES, FRAME_HEADER_BYTES, FRAME_RATE
from wiswarm_zenoh.programs.report import LiveTable, PollRates, format_table
from wiswarm_zenoh.programs.runners import (
    FollowerOptions,
    LeaderOptions,
    run_follower,
    run_leader,
    run_router,
)
from wiswarm_zenoh.programs.ticker import MAX_RATE_HZ
from wiswarm_zenoh.ros2.newest_push import republished_topic
from wiswarm_zenoh.security.checks import check_identity, check_swarm, check_upstream
from wiswarm_zenoh.transport.zenoh_config import (
    LOCAL_ROUTER,
    MODES,
    SessionSpec,
)

DEFAULT_SWARM = "swarm"
SYSTEMS = ("wiswarm", *BASELINES)
BASELINE_RATE = 50.0  # frames/s: the paper's fixed-rate baselines
# Flags only some systems take (default None, so that one given shows) and who takes them.
LEADER_ONLY = {"policy": ("wiswarm",), "timeout": ("wiswarm",), "window": ("wiswarm",),
               "alpha": ("wiswarm",), "control_period": ("wiswarm",), "name": ("wiswarm",),
               "upstream": ("wiswarm",), "site": ("wiswarm",), "in_flight": ("wiswarm",),
               "timeout_floor": ("wiswarm",), "ros2": ("wiswarm",), "ros_domain": ("wiswarm",),
               "ros_namespace": ("wiswarm",), "ros_updates": ("wiswarm",),
               "ros_max_rate": ("wiswarm",),
               "bind": ("udp", "tcp")}
FOLLOWER_ONLY = {"queue": ("wiswarm",), "fragment_size": ("wiswarm",),
                 "congestion": ("push",), "to": ("udp", "tcp"), "source": ("wiswarm",),
                 "ros2_topic": ("wiswarm", "push"), "ros2_waypoints": ("wiswarm",),
                 "newest_only": ("push", "tcp"), "send_buffer": ("tcp",)}


def _add_common(parser: argparse.ArgumentParser, modes: tuple[str, ...]) -> None:
    add_zenoh_arguments(parser, modes)
    parser.add_argument("--duration", type=positive_float(), metavar="SECONDS",
                        help="stop after this long (default: until Ctrl-C)")


def _add_swarm(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--swarm", default=DEFAULT_SWARM, type=node_name("swarm name"),
                        help=f"swarm name, a key chunk (default {DEFAULT_SWARM})")


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
    if getattr(args, "swarm", None) is not None:
        check_swarm(args.config, args.swarm)
    return spec


class _Announce:
    """A ready signal that tells the user the node is up."""

    def __init__(self, text: str) -> None:
        self._text = text

    def set(self) -> None:
        print(self._text, flush=True)


def _listening(spec: SessionSpec) -> list[str]:
    """Where a router listens: its flags, else its config file, else Zenoh's default
    (a map by mode when nothing was set)."""
    endpoints = json.loads(spec.config().get_json("listen/endpoints"))
    return list(endpoints["router"] if isinstance(endpoints, dict) else endpoints)


def _router(args: argparse.Namespace) -> int:
    spec = _spec(args, "router")
    where = ", ".join(_listening(spec))
    # Where access control runs: what it refuses shows at the default level.
    run_router(spec, threading.Event(),
               _Announce(f"wiswarm router: listening on {where} (Ctrl-C to stop)"), args.duration,
               log_verbosity=args.verbose)
    return 0


def _only_for(args: argparse.Namespace, only: dict[str, tuple[str, ...]]) -> None:
    """A flag given to a system that does not take it is the user's to fix."""
    for dest, systems in only.items():
        if getattr(args, dest) is not None and args.system not in systems:
            raise UsageError(f"--{dest.replace('_', '-')} is for --system "
                             f"{'/'.join(systems)}, not {args.system}")


def _given(args: argparse.Namespace, *dests: str) -> dict[str, Any]:
    """The flags given, by name: the others keep their config's defaults."""
    return {dest: getattr(args, dest) for dest in dests if getattr(args, dest) is not None}


def _receiver(args: argparse.Namespace) -> int:
    """``wiswarm leader --system push|udp|tcp``: a baseline's receiver."""
    options = _checked(ReceiverOptions, args.swarm, args.system, args.bind or DEFAULT_BIND,
                       args.record, args.duration)
    spec = _spec(args, "peer")
    table, rates = LiveTable(), PollRates()
    where = "" if args.system == "push" else f" on {options.bind}"
    title = f"wiswarm leader: swarm {args.swarm!r}, {args.system} receiver{where}"

    def show(receiver: Receiver) -> None:
        summary = receiver.summary
        for record in receiver.latest:
            rates.observe(str(record["follower"]), float(record["deliveries"]),
                          summary.uptime_s)
        header = (f"{title} ({summary.policy}), deliveries/s in the polls/s column, "
                  f"up {summary.uptime_s:.0f} s")
        table.show(format_table(receiver.latest, rates.rates, header))

    receiver = run_receiver(spec, options, threading.Event(),
                            _Announce(f"{title}: waiting for frames (Ctrl-C to stop)"), show)
    print("\n".join(["", "summary", *format_table(receiver.latest, rates.rates, title)]))
    return 0


def _leader(args: argparse.Namespace) -> int:
    _only_for(args, LEADER_ONLY)
    if args.system != "wiswarm":
        return _receiver(args)
    config = _checked(LeaderConfig, **_given(args, "policy", "timeout", "window", "alpha",
                                             "in_flight", "timeout_floor", "control_period"))
    if args.site is not None and args.upstream is None:
        raise UsageError("--site names this leader's site in the parent swarm: give the "
                         "parent with --upstream PARENT_SWARM")
    if args.upstream == args.swarm:
        raise UsageError(f"--upstream must be another swarm than --swarm ({args.swarm!r})")
    options = LeaderOptions(args.swarm, config, args.duration, args.record,
                            name=args.name, upstream=args.upstream, site=args.site,
                            bridge=ros2_options(args))
    spec = _spec(args, "peer")
    check_upstream(args.config, args.upstream, args.site or args.swarm)
    table, rates = LiveTable(), PollRates()
    title = f"wiswarm leader: swarm {args.swarm!r}, policy {config.policy}"

    def show(node: Leader) -> None:
        summary = node.summary
        for record in node.stats:
            rates.observe(record.follower, record.polls, summary.uptime_s)
        header = f"{title}, {summary.polls_per_s:.0f} polls/s, up {summary.uptime_s:.0f} s"
        table.show(format_table([r.as_dict() for r in node.stats], rates.rates, header))

    node = run_leader(spec, options, threading.Event(),
                      _Announce(f"{title}: waiting for followers (Ctrl-C to stop)"), show)
    records = [r.as_dict() for r in node.stats]
    print("\n".join(["", "summary", *format_table(records, rates.rates, title)]))
    return 0


def _check_newest_only(args: argparse.Namespace) -> None:
    """Flags that --newest-only excludes, or needs."""
    if args.newest_only:
        if args.congestion == "drop":
            raise UsageError("--newest-only sends each frame once the previous put "
                             "completed: it needs --congestion block (the default), not drop")
        if args.capacity is not None:
            raise UsageError("--capacity sizes the FIFO: --newest-only keeps one frame, "
                             "the newest")
    elif args.send_buffer is not None:
        raise UsageError("--send-buffer is for --newest-only")
    elif args.ros2_topic is not None:
        raise UsageError("--ros2-topic with --system push needs --newest-only")


def _baseline_follower(args: argparse.Namespace) -> int:
    """``wiswarm follower --system push|udp|tcp``: frames pushed at ``--rate`` (newest
    only: each once the previous send completed), or the robot's ROS 2 topic."""
    if args.system != "push" and args.to is None:
        raise UsageError(f"--system {args.system} needs --to HOST:PORT (where "
                         f"wiswarm leader --system {args.system} listens)")
    _check_newest_only(args)
    source = source_of(args)
    newest = bool(args.newest_only)
    options = _checked(BaselineFollowerOptions, args.swarm, (args.id,), args.system,
                       args.rate or (FRAME_RATE if newest else BASELINE_RATE),
                       args.congestion or "block", args.frame_bytes, args.to,
                       args.capacity or DEFAULT_CAPACITY, args.duration, newest,
                       args.send_buffer or NEWEST_SEND_BUFFER, source)
    spec = _spec(args, "peer")
    how = f"{options.congestion} put" if args.system == "push" else f"to {args.to}"
    what = f"{args.frame_bytes}-byte frames at {options.rate:g} Hz"
    if source is not None:
        what = f"the samples of {args.ros2_topic}"
        how += f" on {republished_topic(args.swarm, args.id, args.ros2_topic)}"
    queue = f" into a FIFO of {options.capacity}"
    if newest:
        queue = ", newest only" + (f", send buffer {options.send_buffer} B"
                                   if args.system == "tcp" else "")
    run_baseline_followers(spec, options, threading.Event(), _Announce(
        f"wiswarm follower {args.id}: {what}{queue}, {args.system} ({how}) (Ctrl-C to "
        "stop)"))
    return 0


def _follower(args: argparse.Namespace) -> int:
    check_identity(args.config, args.id)
    _only_for(args, FOLLOWER_ONLY)
    if args.system != "wiswarm":
        return _baseline_follower(args)
    rate = args.rate or FRAME_RATE
    config = _checked(FollowerConfig, **_given(args, "queue", "capacity", "fragment_size"),
                      rate_hz=rate if args.queue == "fifo" else None)
    _check_frame_bytes(args.frame_bytes, config)
    source = source_of(args)
    if args.ros2_waypoints is not None:
        require("ros2")  # the Path is made and serialized here
    options = FollowerOptions(args.swarm, args.id, config, args.frame_bytes, rate,
                              args.duration, source, args.ros2_waypoints, args.ros_domain or 0)
    spec = _spec(args, "peer")
    what = (f"{args.frame_bytes}-byte frames at {rate:g} Hz" if source is None else
            f"the samples of {args.source or args.ros2_topic}")
    run_follower(spec, options, threading.Event(), _Announce(
        f"wiswarm follower {args.id}: {what}, {config.queue} queue (Ctrl-C to stop)"))
    return 0


def _check_frame_bytes(frame_bytes: int, config: FollowerConfig) -> None:
    if not FRAME_HEADER_BYTES <= frame_bytes <= config.max_update_bytes:
        raise UsageError(f"--frame-bytes must be in [{FRAME_HEADER_BYTES}, "
                         f"{config.max_update_bytes}], got {frame_bytes}")


def _demo(args: argparse.Namespace) -> int:
    _check_frame_bytes(args.frame_bytes, FollowerConfig())
    run_dir = run_demo(DemoOptions(args.followers, args.duration, args.policy,
                                   args.frame_bytes, args.rate, str(args.out)))
    print(f"run directory: {run_dir}", file=sys.stdout)
    return 0


def register(subparsers: Any) -> None:
    router = subparsers.add_parser("router", help="a Zenoh router (default: tcp/[::]:7447)")
    _add_common(router, MODES)
    router.set_defaults(func=_router)

    defaults = LeaderConfig()
    leader = subparsers.add_parser(
        "leader", help="poll the followers of a swarm, or receive a baseline's frames",
        description="Polls the followers of a swarm (--system wiswarm), or receives the "
        "frames a baseline's followers push at a fixed rate (push: Zenoh put on "
        "wiswarm/<swarm>/<id>/push; udp, tcp: plain sockets on --bind) and measures them "
        "alike. Either way it publishes the same stats JSON on wiswarm/<swarm>/<id>/stats "
        "and wiswarm/<swarm>/leader/stats and shows them live.")
    _add_swarm(leader)
    leader.add_argument("--system", choices=SYSTEMS, default="wiswarm",
                        help="wiswarm: poll (default); push|udp|tcp: receive that baseline")
    leader.add_argument("--bind", metavar="HOST:PORT", type=host_port(),
                        help=f"udp/tcp: listen here (default {DEFAULT_BIND})")
    leader.add_argument("--policy", choices=sorted(POLICIES),
                        help=f"wiswarm: whom to poll next (default {defaults.policy})")
    leader.add_argument("--timeout", type=positive_float(),
                        help="wiswarm: the longest wait for a reply, in seconds (each "
                        "follower's timeout adapts to its answers below it; default "
                        f"{defaults.timeout})")
    leader.add_argument("--timeout-floor", type=positive_float(), metavar="SECONDS",
                        help="wiswarm: the shortest a follower's adaptive timeout gets "
                        f"(default {defaults.timeout_floor}); raise it where hosts stall "
                        "for longer (hundreds of followers sharing a small machine)")
    leader.add_argument("--in-flight", type=IN_FLIGHT, metavar="K|auto",
                        help="wiswarm: polls out at once, each to another follower (default "
                        "1, the paper's rule: right wherever the polls share a radio "
                        "channel or one bottleneck). auto: the leader finds the number from "
                        "its throughput and keeps adjusting it (stays at 1 on a shared "
                        "channel, climbs where polls wait out round trips a link could "
                        "fill: a cloud leader over a WAN); use a fixed K where it is known, "
                        "about (round trip + one update's time) / that time")
    leader.add_argument("--window", type=positive_int(),
                        help="wiswarm: polls over which each follower's reliability is "
                        f"estimated (default {defaults.window})")
    leader.add_argument("--alpha", type=finite_float(),
                        help=f"wiswarm: weight EMA factor in [0, 1] (default {defaults.alpha})")
    leader.add_argument("--control-period", type=finite_float(0.0), metavar="SECONDS",
                        help="wiswarm: repeat unchanged control information this often "
                        f"(default {LeaderConfig.control_period}); 0 puts it with every poll")
    leader.add_argument("--name", type=node_name("leader name"),
                        help="wiswarm: this leader's name among the swarm's leaders (default: "
                        "host and process id). Any number may run: the oldest polls, the "
                        "others stand by and take over when it goes")
    leader.add_argument("--upstream", metavar="PARENT_SWARM", type=node_name("swarm name"),
                        help="wiswarm: an edge leader: also a follower of the leader of "
                        "PARENT_SWARM (a cloud leader), which polls this site's followers "
                        "through it as <site>.<follower> and sends their control down")
    leader.add_argument("--site", type=node_name("site name"),
                        help="with --upstream: this site's name there (default: --swarm)")
    leader.add_argument("--record", metavar="CSV", type=writable_file(),
                        help="write every delivery to this file (its directory must exist)")
    add_ros2_arguments(leader)
    _add_common(leader, ("peer", "client"))
    leader.set_defaults(func=_leader)

    follower = subparsers.add_parser(
        "follower", help="a follower sending synthetic frames, or what the robot publishes",
        description="A follower taking synthetic frames at --rate, or the samples the "
        "robot already publishes (--source KEYEXPR, --ros2-topic TOPIC). --system wiswarm (the "
        "default) queues them (LIFO: the freshest only) and answers the leader's polls; "
        "push, udp and tcp are the baselines: every frame is stamped into a FIFO of "
        f"--capacity frames (default {DEFAULT_CAPACITY}; a full FIFO drops the new frame) "
        "and sent in order, by Zenoh put (push) or plain sockets to --to (udp: one "
        "datagram a frame; tcp: one connection). push and tcp --newest-only keep only the "
        "newest frame instead and send it the moment the previous send completed.")
    _add_swarm(follower)
    follower.add_argument("--id", required=True, type=node_name("follower id", follower=True),
                          help="this follower's id (a key chunk)")
    follower.add_argument("--system", choices=SYSTEMS, default="wiswarm",
                          help="wiswarm: answer polls (default); push: put every frame on "
                          "wiswarm/<swarm>/<id>/push; udp/tcp: send every frame to --to")
    follower.add_argument("--newest-only", action="store_true", default=None,
                          help="push/tcp: keep only the newest frame (a newer one replaces "
                          "it, an older one never does) and send it the moment the previous "
                          "send completed: the rate adapts to the path, nothing to tune "
                          f"(--rate is the camera's, default {FRAME_RATE:g}). push: the put "
                          "blocks (congestion block), over one batch of Zenoh tx queue and "
                          f"a {NEWEST_SEND_BUFFER}-byte TCP send buffer (--cfg overrides); "
                          "with --ros2-topic TOPIC, the robot's samples go as they came, as "
                          "a ROS 2 topic where a WiSwarm leader's --ros2 republishes it: "
                          "/wiswarm/<swarm>/<id>TOPIC")
    follower.add_argument("--send-buffer", type=positive_int(), metavar="BYTES",
                          help="tcp --newest-only: the socket's SO_SNDBUF (default "
                          f"{NEWEST_SEND_BUFFER}; the kernel doubles it), small so that a "
                          "frame waits in the slot, where a newer one replaces it, not in "
                          "the kernel")
    follower.add_argument("--congestion", choices=sorted(CONGESTION),
                          help="push: block (reliable, the put waits while Zenoh's queues "
                          "are full: the paper's WiFi-TCP; default) or drop (a plain put: "
                          "Zenoh's default)")
    follower.add_argument("--to", metavar="HOST:PORT", type=host_port(),
                          help="udp/tcp: the receiver (wiswarm leader --system udp|tcp)")
    follower.add_argument("--queue", choices=["lifo", "fifo"],
                          help="wiswarm: the follower's queue (default lifo)")
    follower.add_argument("--capacity", type=positive_int(),
                          help=f"queue capacity (default 1; push/udp/tcp: a FIFO of "
                          f"{DEFAULT_CAPACITY}; not with --newest-only)")
    follower.add_argument("--rate", type=positive_float(MAX_RATE_HZ),
                          help=f"frames per second (default {FRAME_RATE:g}; push/udp/tcp: "
                          f"{BASELINE_RATE:g}, the paper's, but {FRAME_RATE:g} with "
                          "--newest-only), and a wiswarm FIFO's rate control")
    follower.add_argument("--fragment-size", type=positive_int(),
                          help="wiswarm: bytes per reply (default "
                          f"{FollowerConfig().fragment_size})")
    follower.add_argument("--frame-bytes", type=positive_int(), default=FRAME_BYTES,
                          help=f"bytes per synthetic frame (default {FRAME_BYTES} = 224x224; "
                          "udp: what fits one datagram)")
    add_source_arguments(follower)
    _add_common(follower, ("peer", "client"))
    follower.set_defaults(func=_follower)

    demo = subparsers.add_parser(
        "swarm-demo", help="router + leader + synthetic followers, live table and plots"
    )
    demo.add_argument("--followers", type=positive_int(), default=6,
                      help="synthetic followers (default 6)")
    demo.add_argument("--duration", type=positive_float(), default=20.0, metavar="SECONDS",
                      help="how long the demo runs (default 20)")
    demo.add_argument("--policy", default="whittle", choices=sorted(POLICIES),
                      help="the leader's polling policy (default whittle)")
    demo.add_argument("--frame-bytes", type=positive_int(), default=FRAME_BYTES,
                      help=f"bytes per synthetic frame (default {FRAME_BYTES})")
    demo.add_argument("--rate", type=positive_float(MAX_RATE_HZ), default=FRAME_RATE,
                      help="frames/s")
    demo.add_argument("--out", default=Path("runs"), type=writable_dir(), metavar="DIR",
                      help="where run directories go (default runs)")
    demo.set_defaults(func=_demo, needs="plots")
