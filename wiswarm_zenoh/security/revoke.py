"""``wiswarm security revoke``: a follower, an edge leader, an observer or a whole site
cut off. Its name goes on the revocation list, and the routers that knew it get their
configs (rules) and password file rewritten without it; running routers restart with
them by themselves, one of a place at a time (``programs.router_reload``), which
refuses its new sessions and ends the one it holds. Its own files are left as they
are: it is the routers that refuse it.
"""

from __future__ import annotations

from pathlib import Path

from wiswarm_zenoh.extras import require
from wiswarm_zenoh.security.credentials import Passwords
from wiswarm_zenoh.security.deploy import write
from wiswarm_zenoh.security.identities import (
    EDGE_LEADER,
    FOLLOWER,
    OBSERVER,
    ROUTER,
    Identity,
    identities,
)
from wiswarm_zenoh.security.places import Access, Texts, places
from wiswarm_zenoh.security.plan import Plan, load
from wiswarm_zenoh.security.revocation import SITE, RevocationList, Revoked, now

REVOCABLE = (FOLLOWER, EDGE_LEADER, OBSERVER)


def _targets(plan: Plan, everyone: list[Identity], name: str) -> list[Identity]:
    """Who revoking ``name`` cuts off: one identity, or each of a site's."""
    if any(site.name == name for site in plan.sites):
        return [identity for identity in everyone if identity.site == name]
    target = next((identity for identity in everyone if identity.name == name), None)
    if target is None:
        near = [i.name for i in everyone if i.site is not None and i.stem == name]
        hint = f" (in a site, name it SITE/{name}: {', '.join(near)})" if near else ""
        raise ValueError(f"no {name!r} here{hint}: see wiswarm security list")
    if target.role not in REVOCABLE:
        instead = (f"revoke its site, {target.site}" if target.site is not None else
                   "make the deployment again with init (a new CA)")
        raise ValueError(f"{name!r} is a {target.role} of {target.site or 'the top'}, which "
                         f"cannot be revoked alone: {instead}")
    return [target]


def revoke(directory: Path, name: str) -> tuple[list[Revoked], list[Path]]:
    """Revoke ``name`` (a common name as ``list`` shows it, or a site): the entries put
    on the list, and the files rewritten (its routers' configs and password files)."""
    require("security")
    directory = directory.resolve()
    plan = load(directory)
    listed = RevocationList.load(directory)
    done = listed.find(name)
    if done is not None:
        raise ValueError(f"{name!r} was already revoked on {done.when}")
    found = places(directory, plan)
    targets = _targets(plan, identities(found), name)
    when = now()
    entries = [Revoked(t.name, t.role, t.site, when, t.serial()) for t in targets]
    if targets[0].name != name:  # a site
        entries.insert(0, Revoked(name, SITE, name, when, None))
    listed.entries += entries
    access = Access(Passwords.load(directory), listed.names())
    # The places that knew them: their own, and the top's for a site's routers.
    sites = {t.site for t in targets} | {None for t in targets if t.role == ROUTER}
    texts: Texts = {}
    for site in sites:
        texts.update(found[site].rendered((), access))
    written = write(directory, plan, access, texts)
    return entries, [*written, listed.save(directory)]
