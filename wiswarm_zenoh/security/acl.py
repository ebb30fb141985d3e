"""The router's access control for one swarm, as data (Zenoh 1.10's ``access_control``).

Everything is denied unless a rule allows it. The router checks each message twice:
``ingress`` when a node sends it in, ``egress`` when the router sends it on to a node,
so receiving a message needs its own rule. A declaration (subscriber, queryable) is
allowed only if its key expression lies inside an allowed one. Nodes are told apart by
their certificate's common name, which only mutual TLS proves.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from wiswarm_zenoh.ros2 import default_namespace
from wiswarm_zenoh.ros2.bridge import NODE_NAME
from wiswarm_zenoh.ros2.graph import ADMIN_SPACE, check_domain, check_namespace, mangle
from wiswarm_zenoh.transport.keys import ROOT, SwarmKeys, check_follower, check_name

ROUTER = "router"
INGRESS, EGRESS = "ingress", "egress"


@dataclass(frozen=True)
class Roster:
    """Who belongs to the swarm, by certificate common name."""

    swarm: str
    leader: str
    followers: tuple[str, ...]
    observers: tuple[str, ...] = ()
    ros2: tuple[int, str | None] | None = None  # the leader's ROS 2 domain and namespace

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
        names = [ROUTER, self.leader, *self.followers, *self.observers]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"node names must differ (router, leader, followers, observers): "
                             f"{', '.join(twice)} given twice")

    @property
    def nodes(self) -> tuple[str, ...]:
        """Every node but the router, leader first."""
        return (self.leader, *self.followers, *self.observers)


def _rule(rule_id: str, messages: list[str], flow: str, key_exprs: list[str]) -> dict[str, Any]:
    return {"id": rule_id, "permission": "allow", "flows": [flow], "messages": messages,
            "key_exprs": key_exprs}


def _ros2_rules(swarm: str, domain: int, namespace: str | None) -> list[dict[str, Any]]:
    """What ``wiswarm leader --ros2`` sends and hears as a ROS 2 node (rmw_zenoh's keys):
    its topics' data (``<ns>/<follower>/<leaf>`` and ``/diagnostics``, any type), Paths
    on ``<ns>/<follower>/waypoints``, and its own node's liveliness tokens."""
    ns = namespace or default_namespace(swarm)
    data = [f"{domain}{ns}/*/*/*/*", f"{domain}/diagnostics/*/*"]
    waypoints = [f"{domain}{ns}/*/waypoints/*/*"]
    tokens = [f"{ADMIN_SPACE}/{domain}/*/*/*/*/%/{mangle(ns)}/{NODE_NAME}/**"]
    return [
        _rule("leader-ros2-publishes", ["put"], INGRESS, data),
        _rule("leader-ros2-subscribes", ["declare_subscriber"], INGRESS, waypoints),
        _rule("leader-ros2-hears-paths", ["put"], EGRESS, waypoints),
        _rule("leader-ros2-tokens", ["liveliness_token"], INGRESS, tokens),
        _rule("leader-ros2-sees-listeners", ["declare_subscriber"], EGRESS, data),
    ]


def access_control(roster: Roster) -> dict[str, Any]:
    """The ``access_control`` section of the router's config for ``roster``."""
    keys = SwarmKeys(roster.swarm)
    p = keys.prefix
    leader_stats, deliveries = keys.leader_stats, f"{p}/leader/deliveries"
    leaders = keys.leaders
    published = [keys.control, keys.all_stats, leader_stats, keys.all_fresh, deliveries]
    watched = [keys.all_stats, leader_stats, keys.all_fresh]
    updates = f"{p}/*/update"
    leader_rules = [
        _rule("leader-publishes", ["put"], INGRESS, published),
        _rule("leader-polls", ["query"], INGRESS, [updates]),
        _rule("leader-gets-replies", ["reply"], EGRESS, [updates]),
        _rule("leader-watches-members", ["declare_liveliness_subscriber", "liveliness_query"],
              INGRESS, [keys.members, leaders, keys.all_sources]),
        # Any holder of the leader's certificate may run as a standby, under its own name.
        _rule("leader-token", ["liveliness_token"], INGRESS, [leaders]),
        # A standby follows the active leader's control and stats, to take over from them.
        _rule("leader-follows-leader", ["declare_subscriber"], INGRESS,
              [keys.control, keys.all_stats, leader_stats]),
        _rule("leader-hears-leader", ["put"], EGRESS, [keys.control, keys.all_stats,
                                                       leader_stats]),
        _rule("leader-sees-tokens", ["liveliness_token"], EGRESS,
              [keys.members, leaders, keys.all_sources]),
        # Who listens and who answers, so that its publishers' matching status and its
        # queriers see the swarm.
        _rule("leader-sees-listeners", ["declare_subscriber", "declare_queryable"], EGRESS,
              [*published, updates]),
    ]
    if roster.ros2 is not None:
        leader_rules += _ros2_rules(roster.swarm, *roster.ros2)
    follower_rules = [
        _rule("followers-subscribe-control", ["declare_subscriber"], INGRESS, [keys.control]),
        _rule("followers-get-control", ["put"], EGRESS, [keys.control]),
    ]
    # Read-only: what the dashboard and ``wiswarm record`` show (stats, fresh updates,
    # deliveries, the tracking records, experiments' points, who leads and who is a
    # member), nothing sent.
    observed = [*watched, deliveries, f"{p}/*/tracking", f"{ROOT}/experiments/*/points"]
    observer_rules = [_rule("observers-subscribe", ["declare_subscriber"], INGRESS, observed),
                      _rule("observers-get-data", ["put"], EGRESS, observed),
                      _rule("observers-watch-tokens", ["declare_liveliness_subscriber",
                                                       "liveliness_query"], INGRESS,
                            [keys.members, leaders]),
                      _rule("observers-see-tokens", ["liveliness_token"], EGRESS,
                            [keys.members, leaders])]
    groups = [("leader", [roster.leader], leader_rules)]
    if roster.followers:
        groups.append(("followers", list(roster.followers), follower_rules))
    for follower in roster.followers:
        own = f"follower-{follower}"
        groups.append((own, [follower], [
            _rule(f"{own}-serves", ["declare_queryable", "reply"], INGRESS,
                  [keys.update(follower)]),
            _rule(f"{own}-is-polled", ["query"], EGRESS, [keys.update(follower)]),
            _rule(f"{own}-is-member", ["liveliness_token"], INGRESS,
                  [keys.member(follower), f"{keys.source(follower)}/**"]),
        ]))
    if roster.observers:
        groups.append(("observers", list(roster.observers), observer_rules))
    # A subject list must not be empty: a group without members gets no subject at all.
    rules = [rule for _, _, group in groups for rule in group]
    subjects = [{"id": name, "cert_common_names": names} for name, names, _ in groups]
    policies = [{"id": name, "subjects": [name], "rules": [r["id"] for r in group]}
                for name, _, group in groups]
    return {"enabled": True, "default_permission": "deny", "rules": rules,
            "subjects": subjects, "policies": policies}
