"""The rules that join sites to a cloud: each site's router dials the cloud's router,
and its edge leader answers the cloud leader's polls for the site's followers, named
``<site>.<follower>`` in the cloud's swarm (``transport.edge``).

A router knows everything that comes through another router by that router's
certificate alone. So the cloud's router gives each site's router what that site's edge
leader may do upstream and no more: serve the pairs ``<site>.*`` (queryables, replies,
members' tokens) and hear the polls for them and the cloud's control for the site, on
its own key (``wiswarm/<cloud>/control/<site>``). The site's router
gives its edge leader the same, and the cloud's router the mirror of it. Another site,
its router or its edge leader's certificate can thus never answer for this site's pairs
at either router; nor can a site's followers reach anything of the cloud's swarm.

Node names repeat across sites (every site has a ``leader``, and may have a ``uav1``),
common names must not: a site's nodes are ``<site>/<name>``, ``/`` being a character
no name may hold. Site names hold no ``.``: ``s1.$*`` must not match another site's
pairs, as it would ``s1.x``'s.
"""

from __future__ import annotations

from collections.abc import Sequence

from wiswarm_zenoh.security.rules import INGRESS, Group, Rule, other, rule
from wiswarm_zenoh.transport.keys import SwarmKeys, check_name

ROUTER = "router"  # every place's first router's name; the cloud's is also its common name
MAX_ROUTERS = 3  # routers per place: one reloads at a time (``programs.router_reload``)


def router_names(count: int) -> tuple[str, ...]:
    """The names of a place's ``count`` routers: ``router``, ``router2``, ..."""
    if not 1 <= count <= MAX_ROUTERS:
        raise ValueError(f"routers per place must be 1 to {MAX_ROUTERS}, got {count}")
    return (ROUTER, *(f"{ROUTER}{k}" for k in range(2, count + 1)))


def check_site(site: str) -> str:
    """A site name: a key chunk without ``.`` (see the module's docstring)."""
    check_name(site, "site name")
    if "." in site:
        raise ValueError(f"site name {site!r} must not contain . (the cloud names its "
                         "followers <site>.<follower>)")
    return site


def site_common_name(site: str, node: str) -> str:
    """The common name of ``node`` (a router, leader or follower) of ``site``."""
    return f"{site}/{node}"


def _serving(group: str, cloud: str, site: str, inward: str) -> tuple[Rule, ...]:
    """What the side that serves ``site``'s pairs in swarm ``cloud`` may do: ``inward``
    is the flow of what it sends into this router."""
    keys = SwarmKeys(cloud)
    pairs = f"{keys.prefix}/{check_site(site)}.$*/update"
    outward = other(inward)
    return (
        rule(f"{group}-serves", ["declare_queryable", "reply"], inward, [pairs]),
        rule(f"{group}-is-polled", ["query"], outward, [pairs]),
        rule(f"{group}-members", ["liveliness_token"], inward,
             [f"{keys.prefix}/members/{site}.$*"]),
        # The site's own control key only: no site hears another's waypoints.
        rule(f"{group}-subscribes-control", ["declare_subscriber"], inward,
             [keys.site_control(site)]),
        rule(f"{group}-gets-control", ["put"], outward, [keys.site_control(site)]),
    )


def cloud_groups(cloud: str, sites: Sequence[str], routers: int = 1) -> list[Group]:
    """On the cloud's routers: each site's routers, for their own site's pairs."""
    return [Group(f"site-{site}", tuple(site_common_name(site, r) for r in router_names(routers)),
                  _serving(f"site-{site}", cloud, site, INGRESS), routers=True)
            for site in sites]


def site_groups(cloud: str, site: str, leader: str, routers: int = 1) -> list[Group]:
    """On ``site``'s routers: its edge leader (common name ``leader``) serving the cloud,
    and the cloud's routers, which poll it and send the cloud's control down."""
    return [Group("edge", (leader,), _serving("edge", cloud, site, INGRESS)),
            Group("cloud", router_names(routers), _serving("cloud", cloud, site, other(INGRESS)),
                  routers=True)]
