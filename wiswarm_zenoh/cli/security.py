"""``wiswarm security init | add-follower | add-site``: a swarm, or a deployment of sites
and a cloud, closed to all but its members, with Zenoh's mutual TLS, passwords and the
routers' access control (see wiswarm_zenoh/security); ``revoke`` and ``list`` in
``security_revoke``."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from wiswarm_zenoh.cli.security_directory import RELOADED, changed
from wiswarm_zenoh.cli.security_revoke import register_revocation
from wiswarm_zenoh.options import (
    LISTEN_ENDPOINT,
    ArgType,
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
from wiswarm_zenoh.security.acl import MAX_COMMON_NAME, Roster
from wiswarm_zenoh.security.credentials import USERS
from wiswarm_zenoh.security.deploy import add_follower, add_site, init
from wiswarm_zenoh.security.hierarchy import MAX_ROUTERS, check_site
from wiswarm_zenoh.security.places import Place, places
from wiswarm_zenoh.security.plan import Plan, SitePlan, load

DEFAULT_SWARM = "swarm"  # as `wiswarm leader|follower`, so that no --swarm is needed there
MAX_PORT = 65535
MAX_DAYS = 36500  # a certificate's end must be a date Python and X.509 can write
# The CA's common name is "wiswarm <swarm> CA".
MAX_SWARM = MAX_COMMON_NAME - len("wiswarm  CA")
_FOLLOWER = node_name("follower id", robot=True, most=MAX_COMMON_NAME)
_HOST = host_name()
T = TypeVar("T")


def _site_and(kind: str, item: ArgType[tuple[T, ...]],
              example: str) -> ArgType[tuple[str, tuple[T, ...]]]:
    """``SITE:ITEMS``: a site name and a list of ``item``."""
    def parse(text: str) -> tuple[str, tuple[T, ...]]:
        site, sep, rest = text.partition(":")
        if not sep:
            raise ValueError(f"expected {example}, got {text[:60]!r}")
        return check_site(site), item.parse(rest)

    return ArgType(kind, parse)


SITE = _site_and("site", listed(_FOLLOWER, "f1,f2"), "SITE:F1,F2")
SITE_HOSTS = _site_and("site hosts", listed(_HOST, "h1,h2"), "SITE:HOST1,HOST2")


def _flag(swarm: str) -> str:
    return "" if swarm == DEFAULT_SWARM else f" --swarm {swarm}"


def _followers(place: Place, followers: tuple[str, ...]) -> list[str]:
    """The commands that start ``followers`` of ``place``."""
    roster = place.roster
    return [f"  wiswarm follower{_flag(roster.swarm)} --id {f} -c {place.directory / f}.json5"
            for f in followers]


def _routers(place: Place) -> list[str]:
    """The commands that start ``place``'s routers."""
    return [f"  wiswarm router -c {place.directory / router}.json5"
            for router in place.roster.router_names]


def _next_steps(place: Place) -> list[str]:
    """The commands that start ``place``'s routers and nodes."""
    roster = place.roster
    upstream = "" if roster.upstream is None else f" --upstream {roster.upstream}"
    return [*_routers(place),
            f"  wiswarm leader{_flag(roster.swarm)}{upstream} -c "
            f"{place.directory / roster.leader}.json5", *_followers(place, roster.followers)]


def _sites(args: argparse.Namespace) -> tuple[SitePlan, ...]:
    hosts = dict(args.site_hosts)
    names = [name for name, _ in args.site]
    unknown = sorted(set(hosts) - set(names))
    if unknown:
        raise UsageError(f"--site-hosts {unknown[0]}: no such site (give it with --site)")
    if args.port + (len(names) + 1) * args.routers - 1 > MAX_PORT:
        raise UsageError(f"--port {args.port}: site k's router listens on PORT + k "
                         f"(x --routers), its others after it, at most {MAX_PORT}")
    return tuple(SitePlan(name, followers, args.port + k * args.routers, hosts.get(name, ()))
                 for k, (name, followers) in enumerate(args.site, start=1))


def _init(args: argparse.Namespace) -> int:
    if (args.followers is None) == (not args.site):
        raise UsageError("give --followers (one swarm) or --site (a deployment of sites "
                         "and a cloud), not both")
    sites = _sites(args)
    try:
        ros2 = ros2_options(args)
        roster = Roster(args.swarm, args.leader, args.followers or (), args.observers,
                        None if ros2 is None else (ros2.domain, ros2.namespace),
                        routers=args.routers)
        plan = Plan(roster, args.hosts, args.days,
                    tuple(args.listen) or (f"tls/0.0.0.0:{args.port}",),
                    tuple(configs.endpoints(args.hosts, args.port)), sites)
        written = init(args.out, plan)
    except (ValueError, OSError) as exc:
        raise UsageError(str(exc)) from None
    directory = args.out.resolve()
    print(f"wiswarm security: {len(written)} files in {directory} (keep *-key.pem secret; "
          "copy each node its own certificate, key, config and ca.pem"
          f"{', each site its directory' if sites else ''})")
    found = places(directory, plan)
    steps = _next_steps(found[None])
    for site in sites:
        steps += [f"  # site {site.name} (its first router listens on port {site.port}):",
                  *_next_steps(found[site.name])]
    print("\n".join([f"start the {'deployment' if sites else 'swarm'} with:", *steps]))
    return 0


def _changed(args: argparse.Namespace, change: Callable[[Path], object]) -> tuple[Path, Plan]:
    """Run ``change`` on the directory ``init`` wrote; its problems in one line."""
    directory, _ = changed(args.out, change)
    return directory, load(directory)


def _rewritten(place: Place) -> str:
    """The files of ``place``'s routers that a change rewrites."""
    return ", ".join(str(place.directory / name) for name in (
        *(f"{router}.json5" for router in place.roster.router_names), USERS))


def _add_follower(args: argparse.Namespace) -> int:
    directory, plan = _changed(args, lambda d: add_follower(d, args.follower, args.site))
    place = places(directory, plan)[args.site]
    print(f"wiswarm security: follower {args.follower} added; rewrote {_rewritten(place)}: "
          f"{RELOADED}. Start it with:")
    print("\n".join(_followers(place, (args.follower,))))
    return 0


def _add_site(args: argparse.Namespace) -> int:
    name, followers = args.site
    directory, plan = _changed(args, lambda d: add_site(d, name, followers, args.hosts))
    found = places(directory, plan)
    print(f"wiswarm security: site {name} added (its first router listens on port "
          f"{plan.site(name).port}); rewrote {_rewritten(found[None])}: {RELOADED}. "
          "Start the site with:")
    print("\n".join(_next_steps(found[name])))
    return 0


def _add_init(commands: Any) -> None:
    start = commands.add_parser("init", help="a new CA, certificates and configs")
    start.add_argument("--out", required=True, metavar="DIR", type=writable_dir(),
                       help="where to write them")
    start.add_argument("--swarm", default=DEFAULT_SWARM,
                       type=node_name("swarm name", most=MAX_SWARM),
                       help=f"swarm name, a key chunk (default {DEFAULT_SWARM}); with --site, "
                       "the cloud's")
    start.add_argument("--followers", type=listed(_FOLLOWER, "f1,f2"), metavar="F1,F2,...",
                       help="follower ids (each one's certificate common name)")
    start.add_argument("--site", type=SITE, action="append", default=[],
                       metavar="SITE:F1,F2",
                       help="instead of --followers: a site and its followers (repeatable). "
                       "Each site gets a directory: its router (dialing the cloud's), its edge "
                       "leader (swarm SITE, --upstream the cloud's swarm) and its followers")
    start.add_argument("--site-hosts", type=SITE_HOSTS, action="append", default=[],
                       metavar="SITE:H1,H2",
                       help="a site's router's host names or addresses (as --hosts; "
                       "repeatable). Site k's router listens on PORT + k")
    start.add_argument("--leader", default="leader",
                       type=node_name("leader name", most=MAX_COMMON_NAME),
                       help="the leader's name (default leader); every site's edge leader's too")
    start.add_argument("--observers",
                       type=listed(node_name("observer name", most=MAX_COMMON_NAME), "o1,o2"),
                       default=(), metavar="O1,...",
                       help="nodes that may read stats and fresh data, nothing else")
    start.add_argument("--hosts", type=listed(_HOST, "h1,h2"), default=(),
                       metavar="H1,...",
                       help="the router's host names or addresses (certificate SANs besides "
                       "localhost and 127.0.0.1; nodes connect to them, default 127.0.0.1)")
    start.add_argument("--port", type=integer(1, MAX_PORT), default=configs.DEFAULT_PORT,
                       help=f"the router's TLS port (default {configs.DEFAULT_PORT})")
    start.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                       type=LISTEN_ENDPOINT,
                       help="where the router listens (repeatable; default tls/0.0.0.0:PORT)")
    start.add_argument("--routers", type=integer(1, MAX_ROUTERS), default=1,
                       help="routers per place (the swarm's, the cloud's, each site's), each "
                       "on the port after the last: nodes fail over between them, and they "
                       "take a revocation one at a time (default 1)")
    start.add_argument("--days", type=integer(1, MAX_DAYS), default=365,
                       help=f"certificate lifetime in days, at most {MAX_DAYS} (default 365)")
    add_ros2_arguments(start, updates=False, what="let the leader run with --ros2: its "
                       "ROS 2 topics, Paths in and node tokens are allowed, nothing more")
    start.set_defaults(func=_init, needs="security")


def register(subparsers: Any) -> None:
    security = subparsers.add_parser(
        "security", help="certificates and access control for a closed swarm",
        description="Makes a certificate authority, a certificate per node and Zenoh "
        "configs: a router listening on TLS only, with mutual TLS and access control by "
        "certificate common name, and clients for the leader, the followers and observers; "
        "with --site, a cloud's router and leader and each site's router, edge leader and "
        "followers, no site able to answer for, read or poll another.")
    commands = security.add_subparsers(dest="action", metavar="ACTION",
                                       parser_class=OneLineParser)
    commands.required = True
    _add_init(commands)
    add = commands.add_parser("add-follower", help="a certificate and config for one more "
                              "follower; rewrites its router's rules")
    add.add_argument("--out", required=True, metavar="DIR", type=writable_dir(),
                     help="the directory init wrote")
    add.add_argument("--site", type=node_name("site name"),
                     help="the follower's site, in a deployment of sites")
    add.add_argument("follower", type=_FOLLOWER, help="the new follower's id")
    add.set_defaults(func=_add_follower, needs="security")
    site = commands.add_parser("add-site", help="a new site of a deployment: its "
                               "certificates and configs; rewrites the cloud's router's rules")
    site.add_argument("--out", required=True, metavar="DIR", type=writable_dir(),
                      help="the directory init --site wrote")
    site.add_argument("--hosts", type=listed(_HOST, "h1,h2"), default=(), metavar="H1,...",
                      help="the site's router's host names or addresses (default 127.0.0.1)")
    site.add_argument("site", type=SITE, metavar="SITE:F1,F2", help="the site and its followers")
    site.set_defaults(func=_add_site, needs="security")
    register_revocation(commands)
