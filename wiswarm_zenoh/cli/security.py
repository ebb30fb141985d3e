"""``wiswarm security init | add-follower``: a swarm closed to all but its members, with
Zenoh's mutual TLS and the router's access control (see wiswarm_zenoh/security)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from wiswarm_zenoh.options import (
    LISTEN_ENDPOINT,
    OneLineParser,
    UsageError,
    add_ros2_arguments,
    host_name,
    integer,
    listed,
    node_name,
    ros2_options,
    writable_dir,
)
from wiswarm_zenoh.security import configs
from wiswarm_zenoh.security.acl import Roster
from wiswarm_zenoh.security.deploy import ROUTER_CONFIG, Plan, add_follower, init

DEFAULT_SWARM = "swarm"  # as `wiswarm leader|follower`, so that no --swarm is needed there


MAX_DAYS = 36500  # a certificate's end must be a date Python and X.509 can write
# X.509 common names are at most 64 characters; the CA's is "wiswarm <swarm> CA".
MAX_NAME = 64
MAX_SWARM = MAX_NAME - len("wiswarm  CA")
_FOLLOWER = node_name("follower id", follower=True, most=MAX_NAME)
def _next_steps(directory: Path, roster: Roster, followers: tuple[str, ...]) -> list[str]:
    swarm = "" if roster.swarm == DEFAULT_SWARM else f" --swarm {roster.swarm}"
    return [f"  wiswarm router -c {directory / ROUTER_CONFIG}",
            f"  wiswarm leader{swarm} -c {directory / roster.leader}.json5",
            *[f"  wiswarm follower{swarm} --id {f} -c {directory / f}.json5" for f in followers]]


def _init(args: argparse.Namespace) -> int:
    try:
        ros2 = ros2_options(args)
        roster = Roster(args.swarm, args.leader, args.followers, args.observers,
                        None if ros2 is None else (ros2.domain, ros2.namespace))
        plan = Plan(roster, args.hosts, args.days,
                    tuple(args.listen) or (f"tls/0.0.0.0:{args.port}",),
                    tuple(configs.endpoints(args.hosts, args.port)))
        written = init(args.out, plan)
    except (ValueError, OSError) as exc:
        raise UsageError(str(exc)) from None
    directory = args.out.resolve()
    print(f"wiswarm security: {len(written)} files in {directory} (keep *-key.pem secret; "
          "copy each node its own certificate, key, config and ca.pem)")
    print("\n".join(["start the swarm with:", *_next_steps(directory, roster,
                                                           roster.followers)]))
    return 0


def _add_follower(args: argparse.Namespace) -> int:
    directory = args.out.resolve()
    try:
        add_follower(directory, args.follower)
    except FileNotFoundError as exc:
        raise UsageError(f"{exc.filename}: not found (run `wiswarm security init --out "
                         f"{args.out}` first)") from None
    except (ValueError, OSError, KeyError) as exc:
        raise UsageError(f"{directory}: {exc}") from None
    print(f"wiswarm security: follower {args.follower} added; restart the router "
          f"({directory / ROUTER_CONFIG}) for its new rules, then start it with:")
    print(f"  wiswarm follower --id {args.follower} -c {directory / args.follower}.json5")
    return 0


def register(subparsers: Any) -> None:
    security = subparsers.add_parser(
        "security", help="certificates and access control for a closed swarm",
        description="Makes a certificate authority, a certificate per node and Zenoh "
        "configs: a router listening on TLS only, with mutual TLS and access control by "
        "certificate common name, and clients for the leader, the followers and observers.")
    commands = security.add_subparsers(dest="action", metavar="ACTION",
                                       parser_class=OneLineParser)
    commands.required = True
    start = commands.add_parser("init", help="a new CA, certificates and configs")
    start.add_argument("--out", required=True, metavar="DIR", type=writable_dir(),
                       help="where to write them")
    start.add_argument("--swarm", default=DEFAULT_SWARM,
                       type=node_name("swarm name", most=MAX_SWARM),
                       help=f"swarm name, a key chunk (default {DEFAULT_SWARM})")
    start.add_argument("--followers", type=listed(_FOLLOWER, "f1,f2"),
                       required=True, metavar="F1,F2,...",
                       help="follower ids (each one's certificate common name)")
    start.add_argument("--leader", default="leader",
                       type=node_name("leader name", most=MAX_NAME),
                       help="the leader's name (default leader)")
    start.add_argument("--observers",
                       type=listed(node_name("observer name", most=MAX_NAME), "o1,o2"),
                       default=(), metavar="O1,...",
                       help="nodes that may read stats and fresh data, nothing else")
    start.add_argument("--hosts", type=listed(host_name(), "h1,h2"), default=(),
                       metavar="H1,...",
                       help="the router's host names or addresses (certificate SANs besides "
                       "localhost and 127.0.0.1; nodes connect to them, default 127.0.0.1)")
    start.add_argument("--port", type=integer(1, 65535), default=configs.DEFAULT_PORT,
                       help=f"the router's TLS port (default {configs.DEFAULT_PORT})")
    start.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                       type=LISTEN_ENDPOINT,
                       help="where the router listens (repeatable; default tls/0.0.0.0:PORT)")
    start.add_argument("--days", type=integer(1, MAX_DAYS), default=365,
                       help=f"certificate lifetime in days, at most {MAX_DAYS} (default 365)")
    add_ros2_arguments(start, updates=False, what="let the leader run with --ros2: its "
                       "ROS 2 topics, Paths in and node tokens are allowed, nothing more")
    start.set_defaults(func=_init, needs="security")
    add = commands.add_parser("add-follower", help="a certificate and config for one more "
                              "follower; rewrites the router's rules")
    add.add_argument("--out", required=True, metavar="DIR", type=writable_dir(),
                     help="the directory init wrote")
    add.add_argument("follower", type=_FOLLOWER,
                     help="the new follower's id")
    add.set_defaults(func=_add_follower, needs="security")
