"""Zenoh 1.10's ``access_control`` as data: rules, and the subjects they are given.

Everything is denied unless a rule allows it. A router checks each message twice:
``ingress`` when a node (or another router) sends it in, ``egress`` when the router
sends it on, so receiving a message needs its own rule. A declaration (subscriber,
queryable) is allowed only if its key expression lies inside an allowed one. Nodes are
told apart by their certificate's common name, which only mutual TLS proves, and by the
user name they logged in with (``credentials``), each bound to the other: a password
alone, or a certificate with another node's password, matches no subject. A router
knows another router, and all that comes through it, by that router's certificate
alone: the router it dialed shows it no user name.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass
from typing import Any

INGRESS, EGRESS = "ingress", "egress"
MESSAGES = ("put", "delete", "declare_subscriber", "query", "reply", "declare_queryable",
            "liveliness_token", "liveliness_query", "declare_liveliness_subscriber")

Rule = dict[str, Any]


def rule(rule_id: str, messages: list[str], flow: str, key_exprs: list[str]) -> Rule:
    """One allowing rule (ids must differ across the whole section)."""
    return {"id": rule_id, "permission": "allow", "flows": [flow], "messages": messages,
            "key_exprs": key_exprs}


def other(flow: str) -> str:
    """The opposite flow: what one side sends in, the other side's router sends on."""
    return EGRESS if flow == INGRESS else INGRESS


def relayed(group: str) -> tuple[Rule, ...]:
    """Everything, both ways: for another router of the same place, which has checked
    what its own nodes send and will check what it sends them."""
    return tuple(rule(f"{group}-{flow}", list(MESSAGES), flow, ["**"])
                 for flow in (INGRESS, EGRESS))


@dataclass(frozen=True)
class Group:
    """The certificate common names of one role, and the rules they get. Nodes log in
    as their common name (a subject binds both); ``routers`` are known by their
    certificate alone."""

    name: str
    common_names: tuple[str, ...]
    rules: tuple[Rule, ...]
    routers: bool = False

    def subjects(self, revoked: Collection[str]) -> list[dict[str, Any]]:
        """One subject per common name not ``revoked`` (a subject's lists match in any
        combination, so one per name keeps each name to its own user name)."""
        return [{"id": f"{self.name}/{name}", "cert_common_names": [name],
                 **({} if self.routers else {"usernames": [name]})}
                for name in self.common_names if name not in revoked]


def section(groups: Sequence[Group], revoked: Collection[str] = ()) -> dict[str, Any]:
    """The ``access_control`` section of a router's config, without the ``revoked``
    common names. A policy's subject list must not be empty: a group left without
    common names gets no policy, and its rules are left out."""
    kept = [(group, subjects) for group in groups
            if (subjects := group.subjects(revoked))]
    return {"enabled": True, "default_permission": "deny",
            "rules": [r for group, _ in kept for r in group.rules],
            "subjects": [subject for _, subjects in kept for subject in subjects],
            "policies": [{"id": group.name, "subjects": [s["id"] for s in subjects],
                          "rules": [r["id"] for r in group.rules]}
                         for group, subjects in kept]}
