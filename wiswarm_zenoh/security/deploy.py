"""A secured swarm's directory: the CA, a certificate, password and config per node,
each place's routers' password file, the revocation list, and the parameters ``init``
was given (``plan``).

A deployment of sites and a cloud is one directory: the cloud's routers, leader and
observers at its top, each site's routers, edge leader and followers in ``<site>/``
(with a copy of ``ca.pem``: a site's directory is all the site needs). One CA signs
them all; the routers' rules keep each site to its own (see ``hierarchy``).

Every config is rendered (and so checked by Zenoh) before any file is written, and a
file is written only if it changed: a running router restarts when its files change
(``programs.router_reload``). The certificates are made with ``pki`` (cryptography, the
security extra), loaded then.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from wiswarm_zenoh.extras import require
from wiswarm_zenoh.security import configs
from wiswarm_zenoh.security.credentials import Passwords, write_private
from wiswarm_zenoh.security.hierarchy import site_common_name
from wiswarm_zenoh.security.places import ROUTER_CONFIG, Access, Place, Texts, places
from wiswarm_zenoh.security.plan import STATE, Plan, SitePlan, load
from wiswarm_zenoh.security.revocation import SITE, RevocationList

__all__ = ["ROUTER_CONFIG", "STATE", "Place", "Plan", "SitePlan", "add_follower",
           "add_site", "init", "load", "places", "write"]


def write(directory: Path, plan: Plan, access: Access, texts: Texts) -> list[Path]:
    """``texts`` (those that changed: each holds a password, so its owner's only), the
    passwords and the plan."""
    written = []
    for path, text in texts.items():
        if not path.exists() or path.read_text() != text:
            written.append(write_private(path, text.encode()))
    access.passwords.save(directory)
    (directory / STATE).write_text(plan.to_json())
    return written


def _open_site(place: Place, top: Path) -> Path:
    """A site's directory, with the CA's certificate (not its key)."""
    place.directory.mkdir(mode=0o700, exist_ok=True)
    ca = place.directory / configs.CA_CERT
    ca.write_bytes((top / configs.CA_CERT).read_bytes())
    return ca


def init(directory: Path, plan: Plan) -> list[Path]:
    """A new CA, certificates, passwords and configs in ``directory``; an existing swarm
    there is kept (FileExistsError): a new CA would lock its nodes out."""
    require("security")
    from wiswarm_zenoh.security import pki

    directory = directory.resolve()
    if (directory / STATE).exists() or (directory / configs.CA_KEY).exists():
        raise FileExistsError(f"{directory} already holds a swarm's CA: use add-follower, "
                              "or another directory")
    found = places(directory, plan)
    access = Access(Passwords())
    for place in found.values():
        access.passwords.issue(map(place.roster.common_name, place.names))
    texts = {path: text for place in found.values()
             for path, text in place.rendered(place.roster.nodes, access).items()}
    directory.mkdir(parents=True, exist_ok=True)
    os.chmod(directory, 0o700)
    authority = pki.new_authority(plan.roster.swarm, plan.days)
    written = list(pki.write_pair(directory, "ca", authority.cert, authority.key))
    for site, place in found.items():
        if site is not None:
            written.append(_open_site(place, directory))
        written += place.issue(authority, plan.days, place.names)
    return written + write(directory, plan, access, texts)


def _access(directory: Path) -> tuple[Access, RevocationList]:
    revoked = RevocationList.load(directory)
    return Access(Passwords.load(directory), revoked.names()), revoked


def add_follower(directory: Path, follower: str, site: str | None = None) -> list[Path]:
    """A certificate, password and config for ``follower`` (of ``site``, in a deployment
    of sites), signed by the swarm's CA, and its routers' configs and password file
    rewritten to include it. A revoked name is refused."""
    require("security")
    from wiswarm_zenoh.security import pki

    directory = directory.resolve()
    plan = load(directory)
    access, revoked = _access(directory)
    if site is None:
        roster = plan.roster
        if plan.sites:
            raise ValueError(f"swarm {roster.swarm!r} has sites: name the follower's site "
                             f"with --site ({', '.join(s.name for s in plan.sites)})")
        revoked.refuse(follower, "follower")
        if follower in roster.followers:
            raise ValueError(f"follower {follower!r} is already in swarm {roster.swarm!r}")
        plan = replace(plan, roster=replace(roster, followers=(*roster.followers, follower)))
    else:
        if not plan.sites:
            raise ValueError(f"swarm {plan.roster.swarm!r} has no sites: add the follower "
                             "without --site")
        old = plan.site(site)
        revoked.refuse(site, SITE)
        revoked.refuse(site_common_name(site, follower), "follower")
        if follower in old.followers:
            raise ValueError(f"follower {follower!r} is already in site {site!r}")
        grown = replace(old, followers=(*old.followers, follower))
        plan = replace(plan, sites=tuple(grown if s is old else s for s in plan.sites))
    place = places(directory, plan)[site]
    access.passwords.issue([place.roster.common_name(follower)])
    texts = place.rendered((follower,), access)
    issued = place.issue(pki.load_authority(directory), plan.days, (follower,))
    return issued + write(directory, plan, access, texts)


def add_site(directory: Path, name: str, followers: tuple[str, ...],
             hosts: tuple[str, ...] = ()) -> list[Path]:
    """A new site of a deployment: its certificates, passwords and configs (its first
    router on the port after the last site's routers), and the cloud's routers' configs
    and password file rewritten for it. A revoked site's name is refused."""
    require("security")
    from wiswarm_zenoh.security import pki

    directory = directory.resolve()
    plan = load(directory)
    access, revoked = _access(directory)
    if not plan.sites:
        raise ValueError(f"swarm {plan.roster.swarm!r} has followers of its own, not sites "
                         "(make a deployment of sites with init --site)")
    revoked.refuse(name, SITE)
    port = max(s.port for s in plan.sites) + plan.roster.routers
    plan = replace(plan, sites=(*plan.sites, SitePlan(name, followers, port, hosts)))
    found = places(directory, plan)
    place = found[name]
    access.passwords.issue(map(place.roster.common_name, place.names))
    texts = {**found[None].rendered((), access), **place.rendered(place.roster.nodes, access)}
    written = [_open_site(place, directory),
               *place.issue(pki.load_authority(directory), plan.days, place.names)]
    return written + write(directory, plan, access, texts)
