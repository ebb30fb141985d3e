"""The router's access control for one swarm, as data (see ``rules`` for how Zenoh 1.10
applies it): who belongs, and what each role may send and receive."""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from typing import Any

from wiswarm_zenoh.core.members import STREAM_SEPARATOR
from wiswarm_zenoh.ros2 import default_namespace
from wiswarm_zenoh.ros2.bridge import NODE_NAME
from wiswarm_zenoh.ros2.graph import ADMIN_SPACE, check_domain, check_namespace, mangle
from wiswarm_zenoh.security.hierarchy import (
    check_site,
    cloud_groups,
    router_names,
    site_common_name,
    site_groups,
)
from wiswarm_zenoh.security.rules import EGRESS, INGRESS, Group, Rule, relayed, rule, section
from wiswarm_zenoh.transport.keys import ROOT, SwarmKeys, check_follower, check_name

MAX_COMMON_NAME = 64  # characters: X.509's limit


@dataclass(frozen=True)
class Roster:
    """Who belongs to the swarm. A site's swarm (named after the site) has the cloud's
    swarm as ``upstream``; a cloud's has its ``sites`` (and no followers of its own).
    Each place (the swarm, the cloud, each site) has ``routers`` routers."""

    swarm: str
    leader: str
    followers: tuple[str, ...]
    observers: tuple[str, ...] = ()
    ros2: tuple[int, str | None] | None = None  # the leader's ROS 2 domain and namespace
    upstream: str | None = None
    sites: tuple[str, ...] = ()
    routers: int = 1

    def __post_init__(self) -> None:
        SwarmKeys(self.swarm)
        if self.ros2 is not None:
            check_domain(self.ros2[0])
            if self.ros2[1] is not None:
                check_namespace(self.ros2[1])
        check_name(self.leader, "leader name")
        for follower in self.followers:
            check_follower(follower)
        for observer in self.observers:
            check_name(observer, "observer name")
        names = [*router_names(self.routers), self.leader, *self.followers, *self.observers]
        _once(names, "node names must differ (routers, leader, followers, observers)")
        self._check_links()
        _once([*names, *self.sites], "site names must differ from the cloud's node names")
        for name in names:
            if ":" in self.common_name(name):  # password files hold "name:password" lines
                raise ValueError(f"name {self.common_name(name)!r} must not contain :")
            if len(self.common_name(name)) > MAX_COMMON_NAME:
                raise ValueError(f"common name {self.common_name(name)!r} is over "
                                 f"{MAX_COMMON_NAME} characters: use shorter names")

    def _check_links(self) -> None:
        if self.upstream is not None:
            SwarmKeys(self.upstream)
            check_site(self.swarm)
            if self.upstream == self.swarm or self.sites:
                raise ValueError(f"site {self.swarm!r} must have another swarm upstream "
                                 "than its own, and no sites of its own")
        for site in self.sites:
            check_site(site)
        _once([self.swarm, *self.sites], "site names must differ from each other and "
              "from the cloud's swarm")
        if self.sites and self.followers:
            raise ValueError(f"swarm {self.swarm!r} has sites: its followers are theirs "
                             "(add them to a site)")

    def common_name(self, node: str) -> str:
        """``node``'s certificate common name: its name, ``<site>/<name>`` in a site."""
        return node if self.upstream is None else site_common_name(self.swarm, node)

    @property
    def nodes(self) -> tuple[str, ...]:
        """Every node but the routers, leader first."""
        return (self.leader, *self.followers, *self.observers)

    @property
    def router_names(self) -> tuple[str, ...]:
        """This place's routers."""
        return router_names(self.routers)


def _once(names: list[str], what: str) -> None:
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ValueError(f"{what}: {', '.join(twice)} given twice")


def _ros2_rules(swarm: str, domain: int, namespace: str | None) -> list[Rule]:
    """What ``wiswarm leader --ros2`` sends and hears as a ROS 2 node (rmw_zenoh's keys):
    its topics' data (``<ns>/<follower>/<leaf>`` and ``/diagnostics``, any type), Paths
    on ``<ns>/<follower>/waypoints`` and weights on ``<ns>/<follower>/weight``, and its
    own node's liveliness tokens. Only the leader's side puts there (``data``): a
    follower can neither steer another nor raise its own weight."""
    ns = namespace or default_namespace(swarm)
    data = [f"{domain}{ns}/*/*/*/*", f"{domain}/diagnostics/*/*"]
    heard = [f"{domain}{ns}/*/waypoints/*/*", f"{domain}{ns}/*/weight/*/*"]
    tokens = [f"{ADMIN_SPACE}/{domain}/*/*/*/*/%/{mangle(ns)}/{NODE_NAME}/**"]
    return [
        rule("leader-ros2-publishes", ["put"], INGRESS, data),
        rule("leader-ros2-subscribes", ["declare_subscriber"], INGRESS, heard),
        rule("leader-ros2-hears-paths", ["put"], EGRESS, heard),
        rule("leader-ros2-tokens", ["liveliness_token"], INGRESS, tokens),
        rule("leader-ros2-sees-listeners", ["declare_subscriber"], EGRESS, data),
    ]


def _leader_rules(roster: Roster) -> list[Rule]:
    keys = SwarmKeys(roster.swarm)
    # A cloud leader's control goes to each site on a key of its own (control/<site>).
    published = [keys.control, keys.all_site_controls, keys.all_stats, keys.leader_stats,
                 keys.all_fresh, keys.leader_deliveries]
    updates = f"{keys.prefix}/*/update"
    rules = [
        rule("leader-publishes", ["put"], INGRESS, published),
        rule("leader-polls", ["query"], INGRESS, [updates]),
        rule("leader-gets-replies", ["reply"], EGRESS, [updates]),
        rule("leader-watches-members", ["declare_liveliness_subscriber", "liveliness_query"],
             INGRESS, [keys.members, keys.leaders, keys.all_sources]),
        # Any holder of the leader's certificate may run as a standby, under its own name.
        rule("leader-token", ["liveliness_token"], INGRESS, [keys.leaders]),
        # Weights are the leader's side's to set (``weight_settings``): its tools hold
        # its certificate; a follower's session may not put them.
        rule("leader-weights", ["declare_subscriber", "put"], INGRESS, [keys.all_weights]),
        rule("leader-gets-weights", ["put"], EGRESS, [keys.all_weights]),
        # A standby follows the active leader's control and stats, to take over from them.
        rule("leader-follows-leader", ["declare_subscriber"], INGRESS,
             [keys.control, keys.all_site_controls, keys.all_stats, keys.leader_stats]),
        rule("leader-hears-leader", ["put"], EGRESS, [keys.control, keys.all_site_controls,
                                                      keys.all_stats, keys.leader_stats]),
        rule("leader-sees-tokens", ["liveliness_token"], EGRESS,
             [keys.members, keys.leaders, keys.all_sources]),
        # Who listens and who answers, so that its publishers' matching status and its
        # queriers see the swarm.
        rule("leader-sees-listeners", ["declare_subscriber", "declare_queryable"], EGRESS,
             [*published, updates]),
    ]
    if roster.ros2 is not None:
        rules += _ros2_rules(roster.swarm, *roster.ros2)
    return rules


def _follower_groups(roster: Roster) -> list[Group]:
    keys = SwarmKeys(roster.swarm)
    cn = roster.common_name
    groups = [Group("followers", tuple(cn(f) for f in roster.followers), (
        rule("followers-subscribe-control", ["declare_subscriber"], INGRESS, [keys.control]),
        rule("followers-get-control", ["put"], EGRESS, [keys.control])))]
    for follower in roster.followers:
        own = f"follower-{follower}"
        # A robot's streams are members <follower>~<stream> (``transport.streams``).
        streams = f"{follower}{STREAM_SEPARATOR}$*"
        updates = [keys.update(follower), f"{keys.prefix}/{streams}/update"]
        groups.append(Group(own, (cn(follower),), (
            rule(f"{own}-serves", ["declare_queryable", "reply"], INGRESS, updates),
            rule(f"{own}-is-polled", ["query"], EGRESS, updates),
            rule(f"{own}-is-member", ["liveliness_token"], INGRESS,
                 [keys.member(follower), f"{keys.source(follower)}/**",
                  f"{keys.prefix}/members/{streams}", f"{keys.prefix}/{streams}/source/**"]),
        )))
    return groups


def _observer_rules(swarm: str) -> tuple[Rule, ...]:
    """Read-only: what the dashboard and ``wiswarm record`` show (stats, fresh updates,
    deliveries, the tracking records, experiments' points, who leads and who is a
    member), nothing sent."""
    keys = SwarmKeys(swarm)
    observed = [keys.all_stats, keys.leader_stats, keys.all_fresh, keys.leader_deliveries,
                f"{keys.prefix}/*/tracking", f"{ROOT}/experiments/*/points"]
    tokens = [keys.members, keys.leaders]
    return (rule("observers-subscribe", ["declare_subscriber"], INGRESS, observed),
            rule("observers-get-data", ["put"], EGRESS, observed),
            rule("observers-watch-tokens", ["declare_liveliness_subscriber",
                                            "liveliness_query"], INGRESS, tokens),
            rule("observers-see-tokens", ["liveliness_token"], EGRESS, tokens))


def access_control(roster: Roster, revoked: Collection[str] = ()) -> dict[str, Any]:
    """The ``access_control`` section of the routers' config for ``roster`` (a site's
    routers or a cloud's: with the rules that join them, see ``hierarchy``), with no
    subject for the ``revoked`` common names."""
    leader = roster.common_name(roster.leader)
    routers = roster.router_names  # each trusts the others of its place (``relayed``)
    siblings = tuple(map(roster.common_name, routers)) if len(routers) > 1 else ()
    groups = [Group("routers", siblings, relayed("routers"), routers=True),
              Group("leader", (leader,), tuple(_leader_rules(roster))),
              *_follower_groups(roster),
              Group("observers", tuple(map(roster.common_name, roster.observers)),
                    _observer_rules(roster.swarm)),
              *cloud_groups(roster.swarm, roster.sites, roster.routers)]
    if roster.upstream is not None:
        groups += site_groups(roster.upstream, roster.swarm, leader, roster.routers)
    return section(groups, revoked)
