"""The places of a deployment, each with its routers and nodes: the swarm's (or the
cloud's) at the top of its directory, each site's in ``<site>/``. Where each router
listens and what it dials, where the nodes connect, and every config rendered (and so
checked by Zenoh) from the passwords and the revoked names.

A place's k-th router (``router``, ``router2``, ...) listens on the port k - 1 after
its first; nodes list them all, the first first, and fail over between them.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wiswarm_zenoh.security import configs
from wiswarm_zenoh.security.acl import Roster
from wiswarm_zenoh.security.credentials import USERS, Passwords
from wiswarm_zenoh.security.hierarchy import ROUTER, site_common_name
from wiswarm_zenoh.security.plan import Plan

if TYPE_CHECKING:  # cryptography is loaded when certificates are made
    from wiswarm_zenoh.security.pki import Authority

ROUTER_CONFIG = f"{ROUTER}.json5"
_PORT = re.compile(r"^(?P<head>[^/]+/.*:)(?P<port>\d+)(?P<tail>[?#].*)?$")

Texts = dict[Path, str]


def shifted(endpoint: str, by: int) -> str:
    """``endpoint`` with its port ``by`` higher: where the place's next router is."""
    found = _PORT.match(endpoint)
    if found is None:
        raise ValueError(f"endpoint {endpoint!r} has no port")
    return f"{found['head']}{int(found['port']) + by}{found['tail'] or ''}"


@dataclass(frozen=True)
class Access:
    """What every config is written with: the passwords, and the revoked common names
    (left out of every router's rules and password file)."""

    passwords: Passwords
    revoked: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Place:
    """One place: its routers and nodes (``roster``), in ``directory``."""

    directory: Path
    roster: Roster
    hosts: tuple[str, ...]  # the routers' names: in every certificate made here
    listen: tuple[str, ...]  # where its first router listens
    dial: tuple[str, ...]  # where its routers connect: a site's, to the cloud's
    connect: tuple[str, ...]  # where the nodes find its first router
    guests: tuple[str, ...] = ()  # other places' routers that dial in (common names)

    @property
    def endpoints(self) -> tuple[str, ...]:
        """Where the nodes connect: every router, the first first."""
        return tuple(shifted(e, k) for k in range(self.roster.routers) for e in self.connect)

    @property
    def names(self) -> tuple[str, ...]:
        """Everyone of the place: its routers, then its nodes."""
        return (*self.roster.router_names, *self.roster.nodes)

    def users(self, revoked: frozenset[str]) -> list[str]:
        """Whom its routers let in: its own routers and nodes, and the guests."""
        names = [*map(self.roster.common_name, self.names), *self.guests]
        return [name for name in names if name not in revoked]

    def router(self, name: str, access: Access) -> str:
        """Router ``name``'s config: it listens on its own port and dials, besides the
        cloud's routers, the routers of its place before it."""
        roster, k = self.roster, self.roster.router_names.index(name)
        where = (f"swarm {roster.swarm!r}" if roster.upstream is None else
                 f"site {roster.swarm!r} under {roster.upstream!r}")
        dial = (*self.dial, *(shifted(e, j) for j in range(k) for e in self.connect))
        auth = access.passwords.router(roster.common_name(name), self.directory / USERS)
        config = configs.router_config(self.directory, roster, name,
                                       [shifted(e, k) for e in self.listen], dial, auth,
                                       access.revoked)
        return configs.render(config, f"{where}: router {name!r} (`wiswarm router -c "
                                      f"{self.directory / name}.json5`)")

    def node(self, name: str, access: Access) -> str:
        roster = self.roster
        upstream = roster.upstream if name == roster.leader else None
        auth = access.passwords.login(roster.common_name(name))
        return configs.render(
            configs.node_config(self.directory, name, self.endpoints, roster.swarm, auth,
                                upstream),
            f"swarm {roster.swarm!r}: node {name!r}, a client of its routers")

    def rendered(self, nodes: Iterable[str], access: Access) -> Texts:
        """The routers' configs and password file, and the configs of ``nodes`` (but the
        revoked ones'), by path."""
        texts = {self.directory / f"{r}.json5": self.router(r, access)
                 for r in self.roster.router_names}
        texts[self.directory / USERS] = access.passwords.file(self.users(access.revoked))
        texts.update({self.directory / f"{node}.json5": self.node(node, access)
                      for node in nodes
                      if self.roster.common_name(node) not in access.revoked})
        return texts

    def issue(self, authority: Authority, days: int, names: Iterable[str]) -> list[Path]:
        """Certificates and keys for ``names``, named in their common name as the
        routers' rules and password files know them."""
        from wiswarm_zenoh.security import pki

        written: list[Path] = []
        for name in names:
            cert, key = pki.issue(authority, self.roster.common_name(name), days, self.hosts)
            written += pki.write_pair(self.directory, name, cert, key)
        return written


def places(directory: Path, plan: Plan) -> dict[str | None, Place]:
    """Every place, by site (None: the top)."""
    routers = plan.roster.router_names
    top = Place(directory, plan.cloud_roster(), plan.hosts, plan.listen, (), plan.connect,
                tuple(site_common_name(s.name, r) for s in plan.sites for r in routers))
    found: dict[str | None, Place] = {None: top}
    for site in plan.sites:
        found[site.name] = Place(directory / site.name, plan.site_roster(site), site.hosts,
                                 (f"tls/0.0.0.0:{site.port}",), top.endpoints,
                                 tuple(configs.endpoints(site.hosts, site.port)))
    return found
