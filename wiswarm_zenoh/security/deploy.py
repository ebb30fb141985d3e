"""A secured swarm's directory: the CA, a certificate and a config per node, and the
parameters ``init`` was given (``security.json``), so a follower added later gets the
same hosts, endpoints and lifetime, and the router's rules are rebuilt whole.

Every config is rendered (and so checked by Zenoh) before any file is written. The
certificates are made with ``pki`` (cryptography, the security extra), loaded then.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from wiswarm_zenoh.extras import require
from wiswarm_zenoh.security import configs
from wiswarm_zenoh.security.acl import ROUTER, Roster

STATE = "security.json"
ROUTER_CONFIG = f"{ROUTER}.json5"


@dataclass(frozen=True)
class Plan:
    """What ``wiswarm security init`` was asked for."""

    roster: Roster
    hosts: tuple[str, ...] = ()
    days: int = 365
    listen: tuple[str, ...] = (f"tls/0.0.0.0:{configs.DEFAULT_PORT}",)
    connect: tuple[str, ...] = (f"tls/127.0.0.1:{configs.DEFAULT_PORT}",)

    def __post_init__(self) -> None:
        if self.days <= 0:
            raise ValueError(f"--days must be positive, got {self.days}")
        for endpoint in (*self.listen, *self.connect):
            if not endpoint.startswith("tls/"):
                raise ValueError(f"endpoint {endpoint!r} must be a tls/HOST:PORT endpoint: "
                                 "the router accepts nothing else")

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
                   listen=tuple(data["listen"]), connect=tuple(data["connect"]))


def _rendered(directory: Path, plan: Plan, nodes: tuple[str, ...]) -> dict[str, str]:
    """File name -> JSON5 text: the router's config and those of ``nodes``."""
    texts = {ROUTER_CONFIG: configs.render(
        configs.router_config(directory, plan.roster, plan.listen), f"swarm "
        f"{plan.roster.swarm!r}: the router (`wiswarm router -c {directory / ROUTER_CONFIG}`)")}
    for node in nodes:
        texts[f"{node}.json5"] = configs.render(
            configs.node_config(directory, node, plan.connect, plan.roster.swarm),
            f"swarm {plan.roster.swarm!r}: node {node!r}, a client of the router")
    return texts


def _write(directory: Path, plan: Plan, texts: dict[str, str]) -> list[Path]:
    written = [directory / name for name in texts]
    for path in written:
        path.write_text(texts[path.name])
    (directory / STATE).write_text(plan.to_json())
    return written


def init(directory: Path, plan: Plan) -> list[Path]:
    """A new CA, certificates and configs in ``directory``; an existing swarm there is
    kept (FileExistsError): a new CA would lock its nodes out."""
    require("security")
    from wiswarm_zenoh.security import pki

    directory = directory.resolve()
    if (directory / STATE).exists() or (directory / configs.CA_KEY).exists():
        raise FileExistsError(f"{directory} already holds a swarm's CA: use add-follower, "
                              "or another directory")
    texts = _rendered(directory, plan, plan.roster.nodes)
    directory.mkdir(parents=True, exist_ok=True)
    os.chmod(directory, 0o700)
    authority = pki.new_authority(plan.roster.swarm, plan.days)
    written = list(pki.write_pair(directory, "ca", authority.cert, authority.key))
    for name in (ROUTER, *plan.roster.nodes):
        cert, key = pki.issue(authority, name, plan.days, plan.hosts)
        written += pki.write_pair(directory, name, cert, key)
    return written + _write(directory, plan, texts)


def load(directory: Path) -> Plan:
    """The plan ``init`` stored in ``directory``."""
    return Plan.from_json((directory / STATE).read_text())


def add_follower(directory: Path, follower: str) -> list[Path]:
    """A certificate and config for ``follower``, signed by the swarm's CA, and the
    router's config rewritten with rules that include it."""
    require("security")
    from wiswarm_zenoh.security import pki

    directory = directory.resolve()
    plan = load(directory)
    roster = plan.roster
    if follower in roster.followers:
        raise ValueError(f"follower {follower!r} is already in swarm {roster.swarm!r}")
    plan = replace(plan, roster=replace(roster, followers=(*roster.followers, follower)))
    texts = _rendered(directory, plan, (follower,))
    authority = pki.load_authority(directory)
    cert, key = pki.issue(authority, follower, plan.days, plan.hosts)
    return [*pki.write_pair(directory, follower, cert, key), *_write(directory, plan, texts)]
