"""The Zenoh JSON5 configs of a secured swarm: TLS-only routers with access control and
a password file, and clients that reach them with their own certificate and password.

Nodes are clients of the routers, never peers: access control filters only what crosses
a router, and peers would talk to each other directly. Every file path is absolute,
so ``-c DIR/node.json5`` works from any directory.
"""

from __future__ import annotations

import json
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

import zenoh

from wiswarm_zenoh.security.acl import Roster, access_control
from wiswarm_zenoh.transport.zenoh_config import RETRY

DEFAULT_PORT = 7447
CA_CERT = "ca.pem"  # the swarm's CA in its directory (``pki`` writes it)
CA_KEY = "ca-key.pem"


def _tls(directory: Path, stem: str, listens: bool) -> dict[str, Any]:
    """Mutual TLS with the swarm's CA; a router also presents its certificate when
    connecting (to other routers), a node only connects."""
    cert, key = str(directory / f"{stem}.pem"), str(directory / f"{stem}-key.pem")
    tls: dict[str, Any] = {"root_ca_certificate": str(directory / CA_CERT),
                           "enable_mtls": True, "connect_certificate": cert,
                           "connect_private_key": key}
    if listens:
        tls.update(listen_certificate=cert, listen_private_key=key)
    return tls


def _common(directory: Path, stem: str, listens: bool, auth: dict[str, Any]) -> dict[str, Any]:
    # No multicast scouting: nobody else joins by being on the same LAN. No shared
    # memory: traffic takes the TLS link, where access control sees it. A router waits
    # for no one at open (Zenoh's 500 ms): its nodes come to it, and it dials in the
    # background, so it restarts (``programs.router_reload``) in milliseconds.
    return {
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False},
                     **({"delay": 0} if listens else {})},
        "transport": {"link": {"protocols": ["tls"], "tls": _tls(directory, stem, listens)},
                      "shared_memory": {"enabled": False}, "auth": auth},
    }


def _connect(endpoints: Sequence[str]) -> dict[str, Any]:
    """Where to connect, trying again from 100 ms on (``zenoh_config.RETRY``), so that a
    node is back within a tenth of a second of its router's restart, or on another."""
    return {"connect": {"endpoints": list(endpoints), "retry": RETRY}} if endpoints else {}


def router_config(directory: Path, roster: Roster, name: str, listen: Sequence[str],
                  dial: Sequence[str], auth: dict[str, Any],
                  revoked: Collection[str] = ()) -> dict[str, Any]:
    """Router ``name`` of the place: listens on TLS only, lets in only those its password
    file lists (``auth``), and denies all that the swarm's rules do not allow; it dials
    (``dial``) the cloud's routers, for a site's, and the place's routers before it.
    Its metadata gives it its turn to restart when its files change
    (``programs.router_reload``): never with another router of its place."""
    ours = {"swarm": roster.swarm, "router": name,
            "reload": {"turn": roster.router_names.index(name), "of": roster.routers}}
    return {"mode": "router", "listen": {"endpoints": list(listen)}, **_connect(dial),
            "metadata": {"wiswarm": ours}, **_common(directory, name, True, auth),
            "access_control": access_control(roster, revoked)}


def node_config(directory: Path, name: str, connect: Sequence[str], swarm: str,
                auth: dict[str, Any], upstream: str | None = None) -> dict[str, Any]:
    """A leader, follower or observer: a client of its routers (the first that answers),
    with its own certificate and password (``auth``). Its metadata names the swarm its
    rules are for (``checks.check_swarm``) and, for an edge leader, the cloud's swarm it
    serves (``checks.check_upstream``)."""
    ours = {"swarm": swarm, "node": name, **({"upstream": upstream} if upstream else {})}
    return {"mode": "client", **_connect(connect), "metadata": {"wiswarm": ours},
            **_common(directory, name, False, auth)}


def endpoints(hosts: Sequence[str], port: int) -> list[str]:
    """Where nodes connect: the router on each of ``hosts`` (this machine if none)."""
    return [f"tls/{host}:{port}" for host in (hosts or ["127.0.0.1"])]


def render(config: dict[str, Any], what: str) -> str:
    """The JSON5 text of ``config``, checked by Zenoh's own parser: a config it refuses
    (an access control rule set that does not parse, say) stops every session."""
    text = f"// {what}: written by `wiswarm security`\n{json.dumps(config, indent=2)}\n"
    zenoh.Config.from_json5(text)
    return text
