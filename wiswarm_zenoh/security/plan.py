"""What ``wiswarm security init`` was asked for, kept in its directory (``security.json``)
so that a follower or site added later gets the same hosts, endpoints, routers and
lifetime, and every router's rules and password file are rebuilt whole."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from wiswarm_zenoh.security import configs
from wiswarm_zenoh.security.acl import Roster

STATE = "security.json"


@dataclass(frozen=True)
class SitePlan:
    """One site: its followers, and its first router's port and host names (SANs, and
    where the site's nodes connect; 127.0.0.1 if none). Its k-th router listens on the
    port k - 1 after it."""

    name: str
    followers: tuple[str, ...]
    port: int
    hosts: tuple[str, ...] = ()


@dataclass(frozen=True)
class Plan:
    """One swarm (``roster``), or a cloud (``roster``, without followers) and its
    ``sites``; ``roster.routers`` routers in each place."""

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
                      upstream=self.roster.swarm, routers=self.roster.routers)

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
                                 None if ros2 is None else (int(ros2[0]), ros2[1]),
                                 routers=int(roster.get("routers", 1))),
                   hosts=tuple(data["hosts"]), days=int(data["days"]),
                   listen=tuple(data["listen"]), connect=tuple(data["connect"]),
                   sites=tuple(SitePlan(s["name"], tuple(s["followers"]), int(s["port"]),
                                        tuple(s["hosts"])) for s in data.get("sites", ())))


def load(directory: Path) -> Plan:
    """The plan ``init`` stored in ``directory``."""
    return Plan.from_json((directory / STATE).read_text())
