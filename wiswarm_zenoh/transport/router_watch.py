"""Tells the user when a node loses its router and when it has one again.

Zenoh reconnects by itself (``zenoh_config.RECONNECT``) but says little about it at the
default log level; a node that is cut off from the swarm must say so, in its own log.
Checked a few times a second from the node's supervision loop (``wait_until_stopped``).
"""

from __future__ import annotations

import logging
import time

import zenoh

log = logging.getLogger(__name__)


class RouterWatch:
    """Logs the moment ``session`` has no router any more, and when it has one again."""

    def __init__(self, session: zenoh.Session, node: str) -> None:
        self._session = session
        self._node = node
        self._connected = self._routers() > 0  # a peer with no router never warns
        self._lost_at: float | None = None

    def _routers(self) -> int:
        return sum(1 for _ in self._session.info.routers_zid())

    def check(self) -> None:
        routers = self._routers()
        if routers and self._lost_at is not None:
            log.warning("%s: router reached again after %.1f s", self._node,
                        time.monotonic() - self._lost_at)
            self._lost_at = None
        elif not routers and self._connected and self._lost_at is None:
            self._lost_at = time.monotonic()
            log.warning("%s: lost its router; reconnecting", self._node)
        self._connected = self._connected or routers > 0
