"""The follower a robot team embeds: answers its leader's polls with the freshest bytes
it was given, and hands it the leader's waypoints."""

from __future__ import annotations

from collections.abc import Callable
from types import TracebackType

import zenoh

from wiswarm_zenoh.core import FollowerConfig, Waypoint
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.follower_node import FollowerNode
from wiswarm_zenoh.transport.source_feed import Source, SourceFeed


class Follower:
    """Follower ``name`` of ``swarm`` on ``session`` until ``close()`` (or the end of a
    ``with`` block): it holds the token ``wiswarm/<swarm>/members/<name>`` (the leader
    finds it by it) and answers polls on ``wiswarm/<swarm>/<name>/update``.

    Give it data with ``offer(bytes)`` at any rate (the last offered is sent: with the
    default LIFO queue of one, only the freshest matters), with ``sampler``, called
    on each poll for a fresh sample (a sensor read at will), or with ``source``, what
    the robot already publishes: ``ZenohSource(key_expr)`` or
    ``wiswarm_zenoh.ros2.Ros2TopicSource(topic)`` (its samples offered as they come,
    stamped with their own time; closed with the follower). ``on_control`` gets this
    follower's waypoints each time the leader sends new ones (on Zenoh's thread).
    ``config`` sets the queue, its capacity and the reply's fragment size.
    """

    def __init__(
        self,
        session: zenoh.Session,
        swarm: str,
        name: str,
        *,
        config: FollowerConfig | None = None,
        on_control: Callable[[list[Waypoint]], None] | None = None,
        sampler: Callable[[], bytes] | None = None,
        source: Source | None = None,
    ) -> None:
        self._node = FollowerNode(session, swarm, name, config, on_control=on_control,
                                  sample_on_poll=sampler)
        try:
            self._feed = None if source is None else source.open(session, self._node)
        except BaseException:
            self._node.close()
            raise

    @property
    def swarm(self) -> str:
        """The swarm this follower is in."""
        return self._node.keys.swarm

    @property
    def name(self) -> str:
        """This follower's id in its swarm."""
        return self._node.follower_id

    @property
    def polls(self) -> int:
        """Polls answered so far."""
        return self._node.polls

    @property
    def offered(self) -> int:
        """Updates offered so far (by ``offer`` or the sampler)."""
        return self._node.offered

    @property
    def bad_input(self) -> BadInputLog:
        """Malformed polls and control messages from the network, counted by key."""
        return self._node.bad_input

    def offer(self, payload: bytes, generated_at: float | None = None) -> bool:
        """Queue ``payload`` for the next poll, stamped now (or at ``generated_at``,
        seconds since the epoch on this machine's clock, for data made earlier); False if
        the queue's rate control dropped it. Thread-safe."""
        return self._node.offer(payload, generated_at)

    @property
    def source(self) -> SourceFeed | None:
        """The open ``source`` (None without one): its samples offered so far, those
        skipped as older than one offered before, those too large to serve."""
        return self._feed

    def close(self) -> None:
        """Leave the swarm: the token goes first, so the leader stops polling."""
        self._node.close()
        if self._feed is not None:
            self._feed.close()

    def __enter__(self) -> Follower:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
