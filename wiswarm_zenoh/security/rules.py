"""Zenoh 1.10's ``access_control`` as data: rules, and the subjects they are given.

Everything is denied unless a rule allows it. A router checks each message twice:
``ingress`` when a node (or another router) sends it in, ``egress`` when the router
sends it on, so receiving a message needs its own rule. A declaration (subscriber,
queryable) is allowed only if its key expression lies inside an allowed one. Nodes are
told apart by their certificate's common name, which only mutual TLS proves; a router
knows another router, and all that comes through it, by that router's certificate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

INGRESS, EGRESS = "ingress", "egress"

Rule = dict[str, Any]


def rule(rule_id: str, messages: list[str], flow: str, key_exprs: list[str]) -> Rule:
    """One allowing rule (ids must differ across the whole section)."""
    return {"id": rule_id, "permission": "allow", "flows": [flow], "messages": messages,
            "key_exprs": key_exprs}


def other(flow: str) -> str:
    """The opposite flow: what one side sends in, the other side's router sends on."""
    return EGRESS if flow == INGRESS else INGRESS


@dataclass(frozen=True)
class Group:
    """One subject: the certificate common names it matches, and the rules they get."""

    name: str
    common_names: tuple[str, ...]
    rules: tuple[Rule, ...]


def section(groups: Sequence[Group]) -> dict[str, Any]:
    """The ``access_control`` section of a router's config. A subject list must not be
    empty: a group without common names gets no subject at all."""
    kept = [group for group in groups if group.common_names]
    return {"enabled": True, "default_permission": "deny",
            "rules": [r for group in kept for r in group.rules],
            "subjects": [{"id": g.name, "cert_common_names": list(g.common_names)}
                         for g in kept],
            "policies": [{"id": g.name, "subjects": [g.name],
                          "rules": [r["id"] for r in g.rules]} for g in kept]}
