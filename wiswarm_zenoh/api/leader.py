"""The leader a robot team embeds: polls its swarm's followers on a Zenoh session it
is given, and hands each fresh update to a handler (a callable, a FIFO or a ring
channel, as zenoh-python's subscribers do)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from types import TracebackType
from typing import Any

import zenoh

from wiswarm_zenoh.api.handlers import Handler, Receiver, deliver_to
from wiswarm_zenoh.core import Delivered, FollowerStats, LeaderConfig
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.bridge import BridgeOptions, LeaderBridge
from wiswarm_zenoh.transport.leader_node import LeaderNode
from wiswarm_zenoh.transport.telemetry import LeaderSummary


class Leader(Receiver[Delivered]):
    """Polls the followers of ``swarm`` on ``session`` until ``close()`` (or the end of a
    ``with`` block), choosing whom to poll next by ``config.policy`` (the Whittle index
    by default), and publishes the swarm's stats on ``wiswarm/<swarm>/...``.

    ``handler`` gets every fresh update (a ``Delivered``: follower, payload, times): a
    callable runs on a poll thread (one call at a time), a ``FifoChannel`` or
    ``RingChannel`` is read with ``recv``, ``try_recv`` or ``for delivery in leader``.
    ``on_join`` and ``on_leave`` get a follower's id as its liveliness token comes and
    goes, ``on_role`` True once this leader polls and False while an older one does (any
    number may run: the others stand by and take over). ``name`` tells leaders apart
    (default: host and process id); ``bridge`` (``wiswarm_zenoh.ros2.Ros2Options``)
    mirrors the swarm to ROS 2. ``stats_period`` (seconds between stats) and
    ``forget_after`` (how long a departed follower's stats stay) default to the leader's
    own; ``epoch`` to the start time in microseconds. ``config`` holds the policy,
    timeouts and control period. Each follower's stats are made while someone subscribes
    to them, or every round with ``every_record`` (for ``stats`` in this process).
    ``weights`` gives members a weight before they join, taken each time one joins."""

    def __init__(
        self,
        session: zenoh.Session,
        swarm: str,
        handler: Handler[Delivered] | None = None,
        *,
        config: LeaderConfig | None = None,
        on_join: Callable[[str], None] | None = None,
        on_leave: Callable[[str], None] | None = None,
        on_role: Callable[[bool], None] | None = None,
        name: str | None = None,
        bridge: BridgeOptions | None = None,
        stats_period: float | None = None,
        forget_after: float | None = None,
        epoch: int | None = None,
        every_record: bool = False,
        weights: Mapping[str, float] | None = None,
    ) -> None:
        on_delivery, channel = deliver_to(handler)
        super().__init__(channel)
        timings: dict[str, Any] = {key: value for key, value in (
            ("stats_period", stats_period), ("forget_after", forget_after))
            if value is not None}
        self._node = LeaderNode(session, swarm, config, on_delivery=on_delivery,
                                on_join=on_join, on_leave=on_leave, on_role=on_role,
                                epoch=epoch, name=name, bridge=bridge,
                                every_record=every_record, weights=weights, **timings)

    @property
    def swarm(self) -> str:
        """The swarm this leader polls."""
        return self._node.keys.swarm

    @property
    def name(self) -> str:
        """This leader's name among the swarm's leaders."""
        return self._node.name

    @property
    def config(self) -> LeaderConfig:
        """The policy, timeouts and estimators this leader runs with."""
        return self._node.config

    @property
    def followers(self) -> list[str]:
        """The followers polled now (those whose token is up)."""
        return self._node.followers

    @property
    def polls(self) -> int:
        """Polls sent so far."""
        return self._node.polls

    @property
    def epoch(self) -> int:
        """This leader's epoch (it rises at each takeover; followers obey the highest)."""
        return self._node.epoch

    @property
    def active(self) -> bool:
        """True while this leader polls; False while it stands by."""
        return self._node.active

    @property
    def stats(self) -> list[FollowerStats]:
        """The last round's followers' stats (``wiswarm/<swarm>/<id>/stats``): those
        someone subscribes to, or with ``every_record`` all of them."""
        return self._node.latest

    @property
    def summary(self) -> LeaderSummary:
        """The last ``wiswarm/<swarm>/leader/stats`` published."""
        return self._node.summary

    @property
    def bridge(self) -> LeaderBridge | None:
        """The bridge opened from the ``bridge`` options (a ``Ros2Bridge``), or None."""
        return self._node.bridge

    @property
    def bad_input(self) -> BadInputLog:
        """Malformed replies from the network, counted by key expression."""
        return self._node.bad_input

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        """Steer ``follower``: its waypoints (``t, x, y, z`` each: when, on the leader's
        clock, in seconds since the epoch, and where, in metres) go out with the next
        poll on ``wiswarm/<swarm>/control`` and reach its ``on_control``. ValueError for
        waypoints the wire does not allow or a follower that is not polled."""
        self._node.set_control(follower, waypoints)

    def observe_urgency(self, follower: str, urgency: float) -> None:
        """Weigh ``follower`` by the application's urgency (how much its freshness matters
        now, >= 0): fed into its weight's moving average, which the policy multiplies
        its age by (``stats`` shows the weight)."""
        self._node.observe_urgency(follower, urgency)

    def close(self) -> None:
        """Stop polling and leave the swarm (a standby leader takes over); a channel's
        deliveries kept so far can still be read."""
        self._close_channel()  # first: a poll thread waiting on a full FIFO goes on
        self._node.close()

    def __enter__(self) -> Leader:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
