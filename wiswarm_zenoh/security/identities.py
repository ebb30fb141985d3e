"""Who holds a certificate of a deployment: every router and node of every place, by
the common name its routers know it by (``wiswarm security list``, and what
``revoke`` may name)."""

from __future__ import annotations

import datetime
from dataclasses import dataclass
from pathlib import Path

from wiswarm_zenoh.security.places import Place

FOLLOWER, OBSERVER, LEADER, EDGE_LEADER, ROUTER = (
    "follower", "observer", "leader", "edge leader", "router")


@dataclass(frozen=True)
class Identity:
    """One certificate holder: its common name, role and site (None: the top), and its
    files' stem in its place's directory."""

    name: str
    role: str
    site: str | None
    stem: str
    directory: Path

    @property
    def certificate(self) -> Path:
        return self.directory / f"{self.stem}.pem"

    def serial(self) -> str | None:
        """Its certificate's serial number, in hex (None if the file is gone)."""
        from cryptography import x509

        if not self.certificate.exists():
            return None
        return f"{x509.load_pem_x509_certificate(self.certificate.read_bytes()).serial_number:x}"

    def expires(self) -> datetime.datetime | None:
        from cryptography import x509

        if not self.certificate.exists():
            return None
        return x509.load_pem_x509_certificate(self.certificate.read_bytes()).not_valid_after_utc


def _role(place: Place, name: str) -> str:
    roster = place.roster
    if name in roster.router_names:
        return ROUTER
    if name == roster.leader:
        return LEADER if roster.upstream is None else EDGE_LEADER
    return FOLLOWER if name in roster.followers else OBSERVER


def identities(found: dict[str | None, Place]) -> list[Identity]:
    """Everyone, place by place (the top first): routers, leader, followers, observers."""
    return [Identity(place.roster.common_name(name), _role(place, name), site, name,
                     place.directory)
            for site, place in found.items() for name in place.names]
