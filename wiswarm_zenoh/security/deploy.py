"""A secured swarm's directory: the CA, a certificate and a config per node, and the
parameters ``init`` was given (``security.json``), so a follower or site added later
gets the same hosts, endpoints and lifetime, and a router's rules are rebuilt whole.

A deployment of sites and a cloud is one directory: the cloud's router, leader and
observers at its top, each site's router, edge leader and followers in ``<site>/``
(with a copy of ``ca.pem``: a site's directory is all the site needs). One CA signs
them all; the routers' rules keep each site to its own (see ``hierarchy``).

Every config is rendered (and so checked by Zenoh) before any file is written. The
certificates are made with ``pki`` (cryptography, the security extra), loaded then.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from wiswarm_zenoh.extras import require
from wiswarm_zenoh.security import configs
from wiswarm_zenoh.security.acl import Roster
from wiswarm_zenoh.security.hierarchy import ROUTER

if TYPE_CHECKING:  # cryptography is loaded when certificates are made
    from wiswarm_zenoh.security.pki import Authority

STATE = "security.json"
ROUTER_CONFIG = f"{ROUTER}.json5"


@dataclass(frozen=True)
class SitePlan:
    """One site: its followers, and its router's port and host names (SANs, and where
    the site's nodes connect; 127.0.0.1 if none)."""

    name: str
    followers: tuple[str, ...]
    port: int
    hosts: tuple[str, ...] = ()


@dataclass(frozen=True)
class Plan:
    """What ``wiswarm security init`` was asked for: one swarm (``roster``), or a cloud
    (``roster``, without followers) and its ``sites``."""

    roster: Roster
    hosts: tuple[str, ...] = ()
    days: int = 365
    listen: tuple[str, ...] = (f"tls/0.0.0.0:{configs.DEFAULT_PORT}",)
    connect: tuple[str, ...] = (f"tls/127.0.0.1:{configs.DEFAULT_PORT}",)
    sites: tuple[SitePlan, ...] = ()

    def __post_init__(self) -> None:
        if self.days <= 0:
            raise ValueError(f"--days must be positive, got {self.days}")
        for endpoint in (*self.listen, *self.connect):
            if not endpoint.startswith("tls/"):
                raise ValueError(f"endpoint {endpoint!r} must be a tls/HOST:PORT endpoint: "
                                 "the router accepts nothing else")
        self.cloud_roster()
        for site in self.sites:
            self.site_roster(site)

    def cloud_roster(self) -> Roster:
        """The top swarm's roster, with its sites."""
        return replace(self.roster, sites=tuple(site.name for site in self.sites))

    def site_roster(self, site: SitePlan) -> Roster:
        """A site's swarm, named after it: its edge leader (named as the cloud's) serves
        the cloud's swarm."""
        return Roster(site.name, self.roster.leader, site.followers, ros2=self.roster.ros2,
                      upstream=self.roster.swarm)

    def site(self, name: str) -> SitePlan:
        for site in self.sites:
            if site.name == name:
                return site
        have = ", ".join(s.name for s in self.sites) or "none"
        raise ValueError(f"no site {name!r} here (sites: {have})")

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str) -> Plan:
        data = json.loads(text)
        roster = data["roster"]
        ros2 = roster.get("ros2")
        return cls(roster=Roster(roster["swarm"], roster["leader"],
                                 tuple(roster["followers"]), tuple(roster["observers"]),
                                 None if ros2 is None else (int(ros2[0]), ros2[1])),
                   hosts=tuple(data["hosts"]), days=int(data["days"]),
                   listen=tuple(data["listen"]), connect=tuple(data["connect"]),
                   sites=tuple(SitePlan(s["name"], tuple(s["followers"]), int(s["port"]),
                                        tuple(s["hosts"])) for s in data.get("sites", ())))


@dataclass(frozen=True)
class Place:
    """One router and its nodes: the cloud (or the only swarm) at the directory's top,
    or a site in ``<site>/``."""

    directory: Path
    roster: Roster
    hosts: tuple[str, ...]  # the router's names: in every certificate made here
    listen: tuple[str, ...]
    dial: tuple[str, ...]  # where the router connects: a site's, to the cloud's
    connect: tuple[str, ...]  # where the nodes connect

    def router(self) -> str:
        roster = self.roster
        where = (f"swarm {roster.swarm!r}" if roster.upstream is None else
                 f"site {roster.swarm!r} under {roster.upstream!r}")
        path = self.directory / ROUTER_CONFIG
        return configs.render(configs.router_config(self.directory, roster, self.listen,
                                                    self.dial),
                              f"{where}: the router (`wiswarm router -c {path}`)")

    def node(self, name: str) -> str:
        roster = self.roster
        upstream = roster.upstream if name == roster.leader else None
        return configs.render(
            configs.node_config(self.directory, name, self.connect, roster.swarm, upstream),
            f"swarm {roster.swarm!r}: node {name!r}, a client of the router")

    def issue(self, authority: Authority, days: int, names: Iterable[str]) -> list[Path]:
        """Certificates and keys for ``names``, named in their common name as the
        router's rules know them."""
        from wiswarm_zenoh.security import pki

        written: list[Path] = []
        for name in names:
            cert, key = pki.issue(authority, self.roster.common_name(name), days, self.hosts)
            written += pki.write_pair(self.directory, name, cert, key)
        return written


def places(directory: Path, plan: Plan) -> dict[str | None, Place]:
    """Every router's place, by site (None: the top)."""
    found: dict[str | None, Place] = {None: Place(
        directory, plan.cloud_roster(), plan.hosts, plan.listen, (), plan.connect)}
    for site in plan.sites:
        found[site.name] = Place(directory / site.name, plan.site_roster(site), site.hosts,
                                 (f"tls/0.0.0.0:{site.port}",), plan.connect,
                                 tuple(configs.endpoints(site.hosts, site.port)))
    return found


Texts = dict[Path, str]


def _rendered(place: Place, nodes: Iterable[str]) -> Texts:
    """The router's config and those of ``nodes``, by path."""
    texts = {place.directory / ROUTER_CONFIG: place.router()}
    texts.update({place.directory / f"{node}.json5": place.node(node) for node in nodes})
    return texts


def _write(directory: Path, plan: Plan, texts: Texts) -> list[Path]:
    for path, text in texts.items():
        path.write_text(text)
    (directory / STATE).write_text(plan.to_json())
    return list(texts)


def _open_site(place: Place, top: Path) -> Path:
    """A site's directory, with the CA's certificate (not its key)."""
    place.directory.mkdir(mode=0o700, exist_ok=True)
    ca = place.directory / configs.CA_CERT
    ca.write_bytes((top / configs.CA_CERT).read_bytes())
    return ca


def init(directory: Path, plan: Plan) -> list[Path]:
    """A new CA, certificates and configs in ``directory``; an existing swarm there is
    kept (FileExistsError): a new CA would lock its nodes out."""
    require("security")
    from wiswarm_zenoh.security import pki

    directory = directory.resolve()
    if (directory / STATE).exists() or (directory / configs.CA_KEY).exists():
        raise FileExistsError(f"{directory} already holds a swarm's CA: use add-follower, "
                              "or another directory")
    found = places(directory, plan)
    texts = {path: text for place in found.values()
             for path, text in _rendered(place, place.roster.nodes).items()}
    directory.mkdir(parents=True, exist_ok=True)
    os.chmod(directory, 0o700)
    authority = pki.new_authority(plan.roster.swarm, plan.days)
    written = list(pki.write_pair(directory, "ca", authority.cert, authority.key))
    for site, place in found.items():
        if site is not None:
            written.append(_open_site(place, directory))
        written += place.issue(authority, plan.days, (ROUTER, *place.roster.nodes))
    return written + _write(directory, plan, texts)


def load(directory: Path) -> Plan:
    """The plan ``init`` stored in ``directory``."""
    return Plan.from_json((directory / STATE).read_text())


def add_follower(directory: Path, follower: str, site: str | None = None) -> list[Path]:
    """A certificate and config for ``follower`` (of ``site``, in a deployment of sites),
    signed by the swarm's CA, and its router's config rewritten with rules that
    include it."""
    require("security")
    from wiswarm_zenoh.security import pki

    directory = directory.resolve()
    plan = load(directory)
    if site is None:
        roster = plan.roster
        if plan.sites:
            raise ValueError(f"swarm {roster.swarm!r} has sites: name the follower's site "
                             f"with --site ({', '.join(s.name for s in plan.sites)})")
        if follower in roster.followers:
            raise ValueError(f"follower {follower!r} is already in swarm {roster.swarm!r}")
        plan = replace(plan, roster=replace(roster, followers=(*roster.followers, follower)))
    else:
        if not plan.sites:
            raise ValueError(f"swarm {plan.roster.swarm!r} has no sites: add the follower "
                             "without --site")
        old = plan.site(site)
        if follower in old.followers:
            raise ValueError(f"follower {follower!r} is already in site {site!r}")
        grown = replace(old, followers=(*old.followers, follower))
        plan = replace(plan, sites=tuple(grown if s is old else s for s in plan.sites))
    place = places(directory, plan)[site]
    texts = _rendered(place, (follower,))
    return [*place.issue(pki.load_authority(directory), plan.days, (follower,)),
            *_write(directory, plan, texts)]


def add_site(directory: Path, name: str, followers: tuple[str, ...],
             hosts: tuple[str, ...] = ()) -> list[Path]:
    """A new site of a deployment: its certificates and configs (its router on the port
    after the last site's), and the cloud's router's config rewritten for it."""
    require("security")
    from wiswarm_zenoh.security import pki

    directory = directory.resolve()
    plan = load(directory)
    if not plan.sites:
        raise ValueError(f"swarm {plan.roster.swarm!r} has followers of its own, not sites "
                         "(make a deployment of sites with init --site)")
    site = SitePlan(name, followers, max(s.port for s in plan.sites) + 1, hosts)
    plan = replace(plan, sites=(*plan.sites, site))
    found = places(directory, plan)
    place = found[name]
    texts = {**_rendered(found[None], ()), **_rendered(place, place.roster.nodes)}
    written = [_open_site(place, directory),
               *place.issue(pki.load_authority(directory), plan.days,
                            (ROUTER, *place.roster.nodes))]
    return written + _write(directory, plan, texts)
