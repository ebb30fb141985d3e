"""Tells the user when a node loses its router and when it has one again, and when
another of its routers carries it after one died (a failover: said once, at WARNING).

Zenoh reconnects by itself (``zenoh_config.RECONNECT``) but says little about it at the
default log level; a node that is cut off from the swarm must say so, in its own log.
Checked a few times a second from the node's supervision loop (``wait_until_stopped``).
A node told where its router is (``endpoints``) that has reached none after
``STARTUP_GRACE`` says so once, with what to check (nothing listening there, or a TLS
router asked without TLS), and says it again the moment one is reached. One that has
reached none by its end says so in one line and its process exits 1 (``NoRouterReached``):
a run that exchanged nothing is not a success.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence

import zenoh

log = logging.getLogger(__name__)

STARTUP_GRACE = 3.0  # seconds a node may take to reach its router before it says so


class NoRouterReached(Exception):
    """A node pointed at a router ended without ever reaching one (already logged)."""


def say_unreached(node: str, endpoints: Sequence[str], waited: float) -> None:
    log.warning("%s: no router reached at %s after %.0f s: is one listening there "
                "(wiswarm router -l ...)? A TLS router takes tls/HOST:PORT and this node's "
                "config from wiswarm security. Still trying", node, ", ".join(endpoints),
                waited)


def say_never_reached(node: str, endpoints: Sequence[str], waited: float) -> None:
    log.error("%s: no router was ever reached at %s in %.0f s: nothing was exchanged. Is "
              "one listening there (wiswarm router -l ...)? A TLS router takes "
              "tls/HOST:PORT and this node's config from wiswarm security", node,
              ", ".join(endpoints), waited)


class RouterWatch:
    """Logs the moment ``session`` has no router any more, and when it has one again."""

    def __init__(self, session: zenoh.Session, node: str,
                 endpoints: Sequence[str] = ()) -> None:
        self._session = session
        self._node = node
        self._endpoints = list(endpoints)  # where its router should be (none: a peer)
        self._started = time.monotonic()
        self._unreached_said = False
        self._carried_by = self._router_ids()  # the routers it has now
        self._connected = bool(self._carried_by)  # a peer with no router never warns
        self._reached = self._connected  # a router, or a peer at its endpoint, ever
        self._lost_at: float | None = None

    def _routers(self) -> int:
        return len(self._router_ids())

    def _router_ids(self) -> set[str]:
        return {str(zid) for zid in self._session.info.routers_zid()}

    def _anyone(self, routers: int) -> bool:
        """A router, or a peer reached at the node's endpoint (which counts too)."""
        return routers > 0 or any(True for _ in self._session.info.peers_zid())

    def check(self) -> None:
        ids = self._router_ids()
        routers = len(ids)
        gone = self._carried_by - ids
        if gone and ids:  # one router died while another carries the node: a failover
            log.warning("%s: router %s is gone; router %s carries it now", self._node,
                        ", ".join(sorted(gone)), ", ".join(sorted(ids)))
        self._carried_by = ids
        if not self._reached:
            self._reached = self._anyone(routers)
            self._check_first(self._reached)
        if routers and self._lost_at is not None:
            log.warning("%s: router reached again after %.1f s (router %s)", self._node,
                        time.monotonic() - self._lost_at, ", ".join(sorted(ids)))
            self._lost_at = None
        elif not routers and self._connected and self._lost_at is None:
            self._lost_at = time.monotonic()
            log.warning("%s: lost its router; reconnecting", self._node)
        self._connected = self._connected or routers > 0

    def _check_first(self, reached: bool) -> None:
        """Before the first router: say so once after the grace, and when it comes."""
        waited = time.monotonic() - self._started
        if reached and self._unreached_said:
            log.warning("%s: router reached, after %.1f s", self._node, waited)
        elif not reached and self._endpoints and not self._unreached_said \
                and waited >= STARTUP_GRACE:
            self._unreached_said = True
            say_unreached(self._node, self._endpoints, waited)

    def finish(self) -> bool:
        """At the node's end, before its session closes: False, said in one line, if it
        was pointed at a router and never reached one (nor a peer there)."""
        self._reached = self._reached or self._anyone(self._routers())
        if self._reached or not self._endpoints:
            return True
        say_never_reached(self._node, self._endpoints, time.monotonic() - self._started)
        return False


class RouterWatches:
    """The watches of several sessions in one process (followers sharing a host), as one."""

    def __init__(self, endpoints: Sequence[str]) -> None:
        self._endpoints = list(endpoints)
        self._watches: list[RouterWatch] = []

    def add(self, session: zenoh.Session, node: str) -> None:
        self._watches.append(RouterWatch(session, node, self._endpoints))

    def check(self) -> None:
        for watch in self._watches:
            watch.check()

    def finish(self) -> bool:
        """``RouterWatch.finish`` of each (each says its own); False if any failed."""
        return all([watch.finish() for watch in self._watches])
