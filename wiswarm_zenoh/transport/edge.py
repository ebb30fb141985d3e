"""An edge leader is a follower upstream: the hierarchy of edge and cloud leaders.

An edge leader polls its site's followers over the shared local channel, one at a time,
as any leader. Upstream, each of those followers appears in the parent swarm as a
follower of its own, ``<site>.<follower>``, served by this process: the cloud leader
polls these over the wide-area link and schedules over all (site, follower) pairs by
its own index, with p per site (a site's pairs share its link: ``core.site_links``) and
A as it sees it.

A cloud poll is answered with the freshest update the edge has delivered from that
follower (a LIFO of one: an older one is never worth the wide-area link), stamped with
its generation time on the edge leader's clock: the edge estimated the follower's clock
offset, the cloud estimates the edge's, so offsets compose, and the age the cloud
reports is the follower's generation to the cloud's delivery across both hops.

Control flows down the same way: the cloud's entry for ``<site>.<follower>``, on the
site's own control key (``wiswarm/<cloud>/control/<site>``: no site hears another's),
is handed to the edge leader as that follower's control, which it broadcasts with its
polls.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence

import zenoh

from wiswarm_zenoh.core import Delivered, FollowerConfig, Waypoint
from wiswarm_zenoh.core.members import SITE_SEPARATOR
from wiswarm_zenoh.transport.follower_node import FollowerNode
from wiswarm_zenoh.transport.keys import check_name

log = logging.getLogger(__name__)

SetControl = Callable[[str, Sequence[Sequence[float]]], None]


def upstream_id(site: str, follower: str) -> str:
    """The follower's name in the parent swarm."""
    return f"{check_name(site, 'site name')}{SITE_SEPARATOR}{follower}"


class Upstream:
    """This edge's followers as followers of ``parent`` (a swarm), named after ``site``.

    Wire it to the edge's ``LeaderNode``: ``on_join``, ``on_leave``, ``on_delivery`` and
    ``on_role`` as its callbacks, and its ``set_control`` as ``set_control`` (then, since
    the leader is made with these callbacks), which takes the cloud's control. ``clock``
    must be the edge leader's: the generation times relayed are on it. It serves the
    cloud only while its leader is the site's active one: a standby edge leader answering
    too would give the cloud two replies to each poll.
    """

    def __init__(self, session: zenoh.Session, parent: str, site: str,
                 clock: Callable[[], float] = time.time,
                 config: FollowerConfig | None = None) -> None:
        self.parent, self.site = parent, check_name(site, "site name")
        self.set_control: SetControl | None = None
        self._session = session
        self._clock = clock
        # One update waiting per follower: the freshest delivered, whole (the cloud's
        # polls fragment it as any follower's).
        self._config = config or FollowerConfig(queue="lifo", capacity=1)
        self._lock = threading.Lock()
        self._members: set[str] = set()  # the site's followers, served or not
        self._active = False  # the edge leader polls the site: serve the cloud
        self._nodes: dict[str, FollowerNode] = {}

    def on_join(self, follower: str) -> None:
        with self._lock:
            self._members.add(follower)
            if not self._active:
                return
        self._serve(follower)

    def on_role(self, active: bool) -> None:
        """The edge leader became the site's active leader, or stood by."""
        with self._lock:
            self._active = active
            members = sorted(self._members)
        if active:
            for follower in members:
                self._serve(follower)
        else:
            self._close_nodes()

    def _serve(self, follower: str) -> None:
        def obey(entry: list[Waypoint], follower: str = follower) -> None:
            if self.set_control is not None:
                self.set_control(follower, entry)

        node = FollowerNode(self._session, self.parent, upstream_id(self.site, follower),
                            self._config, on_control=obey, clock=self._clock)
        with self._lock:
            old = self._nodes.pop(follower, None)
            self._nodes[follower] = node
        if old is not None:
            old.close()
        log.info("follower %s is %s in swarm %s", follower, node.follower_id, self.parent)

    def on_leave(self, follower: str) -> None:
        with self._lock:
            self._members.discard(follower)
            node = self._nodes.pop(follower, None)
        if node is not None:
            node.close()  # its token goes: the cloud sees it leave, its age grows there

    def on_delivery(self, event: Delivered) -> None:
        with self._lock:
            node = self._nodes.get(event.follower)
        if node is not None:
            node.offer(event.payload, generated_at=event.generated_at)

    @property
    def followers(self) -> list[str]:
        """The names this edge serves upstream."""
        with self._lock:
            return [node.follower_id for node in self._nodes.values()]

    def _close_nodes(self) -> None:
        with self._lock:
            nodes, self._nodes = list(self._nodes.values()), {}
        for node in nodes:
            node.close()

    def close(self) -> None:
        self._close_nodes()
