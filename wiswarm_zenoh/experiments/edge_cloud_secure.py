"""Every session of the edge-cloud experiment, open or closed (``--secure``).

Closed, the topology's sites and cloud are one deployment of ``wiswarm security init
--site``, made for the run in a directory removed at its end: every session takes its
node's config (its own certificate; a router, its rules) and the topology's endpoints
over TLS instead of TCP. The relays carry the TLS bytes as they carried TCP's, and each
site's router holds its channel address in its certificate, where the followers reach
it. A site's swarm is then named after the site and the cloud's is ``CLOUD`` in every
setup, as the rules are written for those names: one deployment serves the whole run.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from wiswarm_zenoh.experiments.edge_cloud_topology import (
    EdgeCloud,
    Site,
    client_of_local_router,
    cloud_router,
)
from wiswarm_zenoh.security.acl import Roster
from wiswarm_zenoh.security.deploy import Plan, SitePlan, init
from wiswarm_zenoh.testbed.nodes import ROUTER_PORT
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

CLOUD = "ec-cloud"
LEADER = "leader"


def _over_tls(spec: SessionSpec, config_file: Path | None = None) -> SessionSpec:
    def tls(endpoints: tuple[str, ...]) -> tuple[str, ...]:
        return tuple(f"tls/{e.removeprefix('tcp/')}" for e in endpoints)

    return replace(spec, connect=tls(spec.connect), listen=tls(spec.listen),
                   config_file=None if config_file is None else str(config_file))


class Specs:
    """The sessions of routers, leaders and followers; closed with ``pki``, where the
    deployment is written (the caller removes it)."""

    def __init__(self, net: EdgeCloud, followers: list[str], pki: Path | None = None) -> None:
        self._pki = pki
        if pki is not None:
            init(pki, Plan(Roster(CLOUD, LEADER, ()), days=1, sites=tuple(
                SitePlan(site.name, tuple(followers), ROUTER_PORT, (site.channel.leader_addr,))
                for site in net.sites)))

    @property
    def secure(self) -> bool:
        return self._pki is not None

    def _own(self, spec: SessionSpec, node: str, site: Site | None) -> SessionSpec:
        """``spec`` as ``node`` of ``site`` (None: the cloud) in the deployment."""
        if self._pki is None:
            return spec
        place = self._pki if site is None else self._pki / site.name
        return _over_tls(spec, place / f"{node}.json5")

    def cloud_router(self) -> SessionSpec:
        return self._own(cloud_router(), "router", None)

    def site_router(self, site: Site) -> SessionSpec:
        return self._own(site.router(), "router", site)

    def leader(self, site: Site | None) -> SessionSpec:
        """The cloud leader, or ``site``'s edge leader: beside their router."""
        return self._own(client_of_local_router(), LEADER, site)

    def followers(self, site: Site) -> SessionSpec:
        """Where ``site``'s followers connect, each with its own ``follower_config``."""
        spec = site.placement.follower()
        return spec if self._pki is None else _over_tls(spec)

    def follower_config(self, site: Site, follower: str) -> str | None:
        return None if self._pki is None else str(self._pki / site.name / f"{follower}.json5")
