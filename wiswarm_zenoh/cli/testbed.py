"""``wiswarm testbed up|down|status|set``: the emulated shared channel by hand (Linux, root).

``up`` builds a persistent channel (two network namespaces, a veth pair, tbf on both
ends; or with ``--medium wifi``, ns-3's 802.11 with a station per follower) and says how
to start nodes inside it; ``set`` changes a tbf channel's rate mid-run, ``status`` shows
what crossed it, ``down`` removes it.
"""

from __future__ import annotations

import argparse
from typing import Any

from wiswarm_zenoh.options import (
    RUN_ID,
    OneLineParser,
    UsageError,
    add_channel_arguments,
    add_medium_arguments,
    add_rates,
    channel_spec,
    require_testbed,
    wifi_spec,
)
from wiswarm_zenoh.testbed import (
    Channel,
    LinkCounters,
    list_channels,
    remove_channel,
)
from wiswarm_zenoh.testbed.channel_records import STATE_DIR
from wiswarm_zenoh.testbed.nodes import NO_SHARED_MEMORY, ROUTER_PORT
from wiswarm_zenoh.testbed.ns3_build import Ns3Unavailable
from wiswarm_zenoh.testbed.ownership import locked
from wiswarm_zenoh.testbed.wifi import WifiMedium
from wiswarm_zenoh.testbed.wifi_records import list_media, remove_medium
from wiswarm_zenoh.testbed.wifi_spec import MediumStats, WifiSpec
from wiswarm_zenoh.units import format_rate


def _how_to_run(leader_ns: str, leader_addr: str, follower_ns: str, where: str,
                *after: str) -> str:
    """Commands that start a router, a leader and a follower on their sides."""
    endpoint = f"tcp/{leader_addr}:{ROUTER_PORT}"
    cfg = f"--cfg '{NO_SHARED_MEMORY}'"
    return "\n".join((
        f"run nodes inside it ({where}):",
        f"  ip netns exec {leader_ns} wiswarm router -l {endpoint} {cfg}",
        f"  ip netns exec {leader_ns} wiswarm leader --swarm s1 -e {endpoint} {cfg}",
        f"  ip netns exec {follower_ns} wiswarm follower --swarm s1 --id uav1 "
        f"-m client -e {endpoint} {cfg}",
        *after,
    ))


def _up_wifi(args: argparse.Namespace, spec: WifiSpec) -> int:
    medium = WifiMedium(spec, name=args.name)
    try:
        medium.build(persistent=True)
    except (ValueError, Ns3Unavailable) as exc:
        raise UsageError(str(exc)) from None
    print(medium.describe())
    print(_how_to_run(medium.leader_ns, medium.leader_addr, medium.station_namespaces[0],
                      "one follower per station namespace; shared memory off",
                      f"remove it:       wiswarm testbed down {medium.run_id}"))
    print(f"run id: {medium.run_id}")
    return 0


def _up(args: argparse.Namespace) -> int:
    spec = wifi_spec(args, args.stations)
    if spec is not None:
        require_testbed()
        return _up_wifi(args, spec)
    channel = Channel(channel_spec(args), name=args.name)
    require_testbed()
    try:
        channel.build(persistent=True)
    except ValueError as exc:  # the name is taken
        raise UsageError(str(exc)) from None
    print(channel.describe())
    print(_how_to_run(channel.leader_ns, channel.leader_addr, channel.follower_ns,
                      "shared memory off, or frames would not cross the link",
                      f"change its rate: wiswarm testbed set --rate 5mbit {channel.run_id}",
                      f"remove it:       wiswarm testbed down {channel.run_id}"))
    print(f"run id: {channel.run_id}")
    return 0


def _down(args: argparse.Namespace) -> int:
    require_testbed()
    kinds = (("testbed channel", list_channels, remove_channel),
             ("WiFi medium", list_media, remove_medium))
    if args.run_id is not None:
        for kind, _, remove in kinds:
            try:
                remove(args.run_id)
            except LookupError:
                continue
            print(f"removed {kind} {args.run_id}")
            return 0
        present = [*list_channels(), *list_media()]
        raise UsageError(f"no testbed channel or WiFi medium {args.run_id!r} (present: "
                         f"{', '.join(present) or 'none'})")
    removed = 0
    for kind, present_ids, remove in kinds:
        for run_id in present_ids():
            try:
                remove(run_id)
            except LookupError:
                continue  # its owner removed it meanwhile
            print(f"removed {kind} {run_id}")
            removed += 1
    if not removed:
        print("no testbed channels to remove")
    return 0


def _counters(label: str, rate_bps: int, counters: LinkCounters) -> str:
    return (f"  {label:<8} {format_rate(rate_bps):>8}: sent {counters.sent_bytes} bytes in "
            f"{counters.sent_packets} packets, {counters.dropped} dropped, backlog "
            f"{counters.backlog_bytes} bytes")


def _medium_counters(stats: MediumStats) -> str:
    def total(name: str) -> int:
        return int(stats.total(name))

    return (f"  air: {total('acked')} frames acknowledged, {total('nacked')} failed "
            f"transmissions (collisions, retried), {total('drop_retry')} dropped at the "
            f"retry limit, {total('drop_queue')} refused by full queues, airtime "
            f"{stats.total('tx_airtime_s'):.1f} s over {stats.t:.0f} s")


def _status(args: argparse.Namespace) -> int:
    require_testbed()
    shown = 0
    for run_id in list_media():
        try:
            medium = WifiMedium.attach(run_id)
        except LookupError:
            continue  # removed meanwhile
        if shown:
            print()
        print(medium.describe())
        print(_medium_counters(medium.stats()))
        shown += 1
    for run_id in list_channels():
        with locked(STATE_DIR):  # a channel is removed under this lock: none half-gone here
            try:
                channel = Channel.attach(run_id)
            except LookupError:
                continue  # removed meanwhile
            spec = channel.spec
            if shown:
                print()
            print(channel.describe())
            print(_counters("uplink", spec.rate_bps, channel.uplink()))
            print(_counters("downlink", spec.down_bps, channel.downlink()))
        shown += 1
    if not shown:
        print("no testbed channels (make one with `wiswarm testbed up`)")
    return 0


def _only_channel() -> str:
    present = list_channels()
    if len(present) == 1:
        return present[0]
    if not present:
        raise UsageError("no testbed channel: make one with `wiswarm testbed up`")
    raise UsageError(f"{len(present)} testbed channels are present ({', '.join(present)}): "
                     "give the run id")


def _set(args: argparse.Namespace) -> int:
    require_testbed()
    run_id = args.run_id or _only_channel()
    try:
        channel = Channel.attach(run_id)
    except LookupError as exc:
        raise UsageError(str(exc)) from None
    before = channel.spec
    try:
        channel.set_rate(args.rate, args.down_rate)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    after = channel.spec
    print(f"testbed channel {run_id}: uplink {format_rate(before.rate_bps)} -> "
          f"{format_rate(after.rate_bps)}, downlink {format_rate(before.down_bps)} -> "
          f"{format_rate(after.down_bps)}")
    return 0


def register(subparsers: Any) -> None:
    """Add ``testbed`` (up, down, status, set)."""
    testbed = subparsers.add_parser(
        "testbed", help="an emulated shared channel of namespaces and tc tbf (root)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = testbed.add_subparsers(dest="action", metavar="ACTION",
                                     parser_class=OneLineParser)
    actions.required = True

    up = actions.add_parser(
        "up", help="build a channel that stays until `down`",
        description="Build a persistent channel: a leader-side and a follower-side network "
                    "namespace joined by a veth pair, each end's egress shaped by tc tbf. "
                    "Prints what it built, how to start nodes in it, and its run id.")
    add_channel_arguments(up)
    add_medium_arguments(up, stations=True)
    up.add_argument("--name", type=RUN_ID,
                    help="the run id to use: 1-24 letters, digits, '-' or '_' (default: "
                    "made up, printed)")
    up.set_defaults(func=_up)

    down = actions.add_parser(
        "down", help="remove a channel, or every one",
        description="Remove the channel RUN_ID, or every testbed channel (wsw-* namespaces) "
                    "when no id is given, whoever made them.")
    down.add_argument("run_id", nargs="?", metavar="RUN_ID", type=RUN_ID,
                      help="the channel to remove")
    down.set_defaults(func=_down)

    status = actions.add_parser(
        "status", help="channels, their rates and what crossed them",
        description="List every channel: rates, queue, namespaces and addresses, and each "
                    "direction's tbf counters (bytes and packets sent, tail drops, backlog).")
    status.set_defaults(func=_status)

    set_rate = actions.add_parser(
        "set", help="change a channel's rate while nodes run",
        description="Change the rates of a channel mid-run (tc qdisc change: queued packets "
                    "stay). Without --down-rate the downlink takes --rate too.")
    add_rates(set_rate, rate_required=True)
    set_rate.add_argument("run_id", nargs="?", metavar="RUN_ID", type=RUN_ID,
                          help="the channel (optional when exactly one exists)")
    set_rate.set_defaults(func=_set)
