"""The Zenoh JSON5 configs of a secured swarm: a TLS-only router with access control, and
clients that reach it with their own certificate.

Nodes are clients of the router, never peers: access control filters only what crosses
the router, and peers would talk to each other directly. Every file path is absolute,
so ``-c DIR/node.json5`` works from any directory.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import zenoh

from wiswarm_zenoh.security.acl import Roster, access_control

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


def _common(directory: Path, stem: str, listens: bool) -> dict[str, Any]:
    # No multicast scouting: nobody else joins by being on the same LAN. No shared
    # memory: traffic takes the TLS link, where access control sees it.
    return {
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
        "transport": {"link": {"protocols": ["tls"], "tls": _tls(directory, stem, listens)},
                      "shared_memory": {"enabled": False}},
    }


def router_config(directory: Path, roster: Roster, listen: Sequence[str],
                  dial: Sequence[str] = ()) -> dict[str, Any]:
    """The router: listens on TLS only, denies all that the swarm's rules do not allow;
    a site's router also dials the cloud's (``dial``)."""
    return {"mode": "router", "listen": {"endpoints": list(listen)},
            **({"connect": {"endpoints": list(dial)}} if dial else {}),
            **_common(directory, "router", listens=True),
            "access_control": access_control(roster)}


def node_config(directory: Path, name: str, connect: Sequence[str], swarm: str,
                upstream: str | None = None) -> dict[str, Any]:
    """A leader, follower or observer: a client of the router, with its own certificate.
    Its metadata names the swarm its rules are for (``checks.check_swarm``) and, for an
    edge leader, the cloud's swarm it serves (``checks.check_upstream``)."""
    ours = {"swarm": swarm, "node": name, **({"upstream": upstream} if upstream else {})}
    return {"mode": "client", "connect": {"endpoints": list(connect)},
            "metadata": {"wiswarm": ours}, **_common(directory, name, listens=False)}


def endpoints(hosts: Sequence[str], port: int) -> list[str]:
    """Where nodes connect: the router on each of ``hosts`` (this machine if none)."""
    return [f"tls/{host}:{port}" for host in (hosts or ["127.0.0.1"])]


def render(config: dict[str, Any], what: str) -> str:
    """The JSON5 text of ``config``, checked by Zenoh's own parser: a config it refuses
    (an access control rule set that does not parse, say) stops every session."""
    text = f"// {what}: written by `wiswarm security`\n{json.dumps(config, indent=2)}\n"
    zenoh.Config.from_json5(text)
    return text
