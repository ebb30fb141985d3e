"""``wiswarm leader``: poll a swarm's followers (``--system wiswarm``), or receive a
baseline's frames (``--system push|udp|tcp``) and measure them alike."""

from __future__ import annotations

import argparse
import threading
from typing import Any

from wiswarm_zenoh import Leader
from wiswarm_zenoh.baselines import DEFAULT_BIND, Receiver, ReceiverOptions, run_receiver
from wiswarm_zenoh.cli.node_flags import (
    SYSTEMS,
    Announce,
    add_common,
    add_swarm,
    checked,
    given,
    only_for,
    session_spec,
)
from wiswarm_zenoh.core import POLICIES, LeaderConfig
from wiswarm_zenoh.options import (
    IN_FLIGHT,
    UsageError,
    add_ros2_arguments,
    add_weight_argument,
    finite_float,
    host_port,
    node_name,
    positive_float,
    positive_int,
    preset_weights,
    ros2_options,
    writable_file,
)
from wiswarm_zenoh.programs.report import LiveTable, PollRates, format_table
from wiswarm_zenoh.programs.runners import LeaderOptions, run_leader
from wiswarm_zenoh.security.checks import check_upstream

# Flags only the polling leader or a receiver takes (default None, so that one given
# shows) and who takes them.
LEADER_ONLY = {"policy": ("wiswarm",), "timeout": ("wiswarm",), "window": ("wiswarm",),
               "alpha": ("wiswarm",), "control_period": ("wiswarm",), "name": ("wiswarm",),
               "upstream": ("wiswarm",), "site": ("wiswarm",), "in_flight": ("wiswarm",),
               "timeout_floor": ("wiswarm",), "ros2": ("wiswarm",), "ros_domain": ("wiswarm",),
               "ros_namespace": ("wiswarm",), "ros_updates": ("wiswarm",),
               "ros_max_rate": ("wiswarm",), "weight": ("wiswarm",),
               "bind": ("udp", "tcp")}

def _receiver(args: argparse.Namespace) -> int:
    """``wiswarm leader --system push|udp|tcp``: a baseline's receiver."""
    options = checked(ReceiverOptions, args.swarm, args.system, args.bind or DEFAULT_BIND,
                       args.record, args.duration)
    spec = session_spec(args, "peer")
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
                            Announce(f"{title}: waiting for frames (Ctrl-C to stop)"), show)
    print("\n".join(["", "summary", *format_table(receiver.latest, rates.rates, title)]))
    return 0


def _leader(args: argparse.Namespace) -> int:
    only_for(args, LEADER_ONLY)
    if args.system != "wiswarm":
        return _receiver(args)
    config = checked(LeaderConfig, **given(args, "policy", "timeout", "window", "alpha",
                                             "in_flight", "timeout_floor", "control_period"))
    if args.site is not None and args.upstream is None:
        raise UsageError("--site names this leader's site in the parent swarm: give the "
                         "parent with --upstream PARENT_SWARM")
    if args.upstream == args.swarm:
        raise UsageError(f"--upstream must be another swarm than --swarm ({args.swarm!r})")
    options = LeaderOptions(args.swarm, config, args.duration, args.record,
                            name=args.name, upstream=args.upstream, site=args.site,
                            bridge=ros2_options(args), weights=preset_weights(args.weight))
    spec = session_spec(args, "peer")
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
                      Announce(f"{title}: waiting for followers (Ctrl-C to stop)"), show)
    records = [r.as_dict() for r in node.stats]
    print("\n".join(["", "summary", *format_table(records, rates.rates, title)]))
    return 0


def register_leader(subparsers: Any) -> None:
    defaults = LeaderConfig()
    leader = subparsers.add_parser(
        "leader", help="poll the followers of a swarm, or receive a baseline's frames",
        description="Polls the followers of a swarm (--system wiswarm), or receives the "
        "frames a baseline's followers push at a fixed rate (push: Zenoh put on "
        "wiswarm/<swarm>/<id>/push; udp, tcp: plain sockets on --bind) and measures them "
        "alike. Either way it publishes the same stats JSON on wiswarm/<swarm>/<id>/stats "
        "and wiswarm/<swarm>/leader/stats and shows them live.")
    add_swarm(leader)
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
    add_weight_argument(leader)
    add_ros2_arguments(leader)
    add_common(leader, ("peer", "client"))
    leader.set_defaults(func=_leader)
