"""Watching a swarm without taking part, for tools: its leader's stats, each follower's
stats and the leader's stream of deliveries, checked and typed (anyone may publish on a
swarm's keys: what does not parse is counted and logged with its key, and skipped)."""

from __future__ import annotations

import dataclasses
import logging
import math
import typing
from dataclasses import dataclass
from types import TracebackType
from typing import Any, TypeAlias, TypeVar

import zenoh

from wiswarm_zenoh.api.handlers import Handler, Receiver, deliver_to
from wiswarm_zenoh.core import FollowerStats
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.keys import SwarmKeys, check_follower
from wiswarm_zenoh.transport.telemetry import LeaderSummary
from wiswarm_zenoh.transport.watch import Watch, json_payload

log = logging.getLogger(__name__)


OUTCOMES = ("delivered", "timeout")


@dataclass(frozen=True)
class DeliveryRecord:
    """One entry of ``wiswarm/<swarm>/leader/deliveries``: ``outcome`` "delivered" (an
    update generated at ``generated_at``) or "timeout" (a poll unanswered, ``generated_at``
    None), at ``delivered_at``; times on the leader's clock, in seconds."""

    follower: str
    outcome: str
    generated_at: float | None
    delivered_at: float


R = TypeVar("R", FollowerStats, LeaderSummary, DeliveryRecord)
Observation: TypeAlias = LeaderSummary | FollowerStats | DeliveryRecord
"""What an ``Observer`` hands on: match on its type."""


def typed(cls: type[R], record: Any) -> R:
    """``record`` (a JSON object) as ``cls``: each field of the right type, a missing one
    at its default (or NaN, 0, "" when it has none); ValueError naming a wrong one."""
    if not isinstance(record, dict):
        raise ValueError(f"stats must be a JSON object, got {type(record).__name__}")
    hints = typing.get_type_hints(cls)
    values: dict[str, Any] = {}
    for field in dataclasses.fields(cls):
        kind = hints[field.name]
        if field.name not in record:
            if field.default is dataclasses.MISSING:
                values[field.name] = {float: math.nan, int: 0, str: "", list[str]: [],
                                      float | None: None}[kind]
            continue
        value = record[field.name]
        if kind == float | None and value is None:
            pass
        elif kind in (float, float | None) and isinstance(value, int | float) \
                and not isinstance(value, bool):
            value = float(value)
        elif kind is list[str] and isinstance(value, list) and all(
                isinstance(item, str) for item in value):
            value = list(value)
        elif kind not in (float, float | None, list[str]) and not (
                isinstance(value, kind) and (kind is bool or not isinstance(value, bool))):
            raise ValueError(f"{field.name} must be {getattr(kind, '__name__', kind)}, "
                             f"got {value!r:.40}")
        values[field.name] = value
    return cls(**values)


def delivery_record(item: Any) -> DeliveryRecord:
    """One record of a deliveries batch; ValueError for one that says nothing sensible."""
    record = typed(DeliveryRecord, item)
    check_follower(record.follower)
    if record.outcome not in OUTCOMES or not math.isfinite(record.delivered_at) \
            or (record.generated_at is None) != (record.outcome == "timeout"):
        raise ValueError(f"not a delivery record: {item!r:.100}")
    return record


class Observer(Receiver[Observation]):
    """Subscribes to the stats and delivery stream of ``swarm`` on ``session`` until
    ``close()`` (or the end of a ``with`` block); nothing is sent, so no leader slows.

    ``handler`` gets every ``Observation`` as it comes: a ``LeaderSummary``
    (``leader/stats``, at least 2 Hz), a ``FollowerStats`` (``<follower>/stats``) or a
    ``DeliveryRecord`` (``leader/deliveries``, in batches at 10 Hz); a callable runs on
    Zenoh's thread, a channel is read with ``recv``, ``try_recv`` or a ``for`` loop.
    ``leader`` and ``followers`` keep the latest stats for a look at any time.
    """

    def __init__(self, session: zenoh.Session, swarm: str,
                 handler: Handler[Observation] | None = None) -> None:
        self._keys = SwarmKeys(swarm)
        self._emit, channel = deliver_to(handler)
        super().__init__(channel)
        self._leader: LeaderSummary | None = None
        self._followers: dict[str, FollowerStats] = {}
        self.bad_input = BadInputLog(log)
        self._watch = Watch(session, {
            self._keys.all_stats: json_payload(self._on_stats),
            self._keys.leader_deliveries: json_payload(self._on_deliveries),
        }, self.bad_input)

    @property
    def swarm(self) -> str:
        """The swarm watched."""
        return self._keys.swarm

    @property
    def leader(self) -> LeaderSummary | None:
        """The active leader's last ``leader/stats`` (None before the first)."""
        return self._leader

    @property
    def followers(self) -> dict[str, FollowerStats]:
        """Each follower's last stats, by id."""
        return dict(self._followers)

    def _on_stats(self, key: str, data: Any) -> None:
        """``leader/stats`` and every follower's (one subscriber: ``*/stats`` has both)."""
        if key == self._keys.leader_stats:
            self._leader = typed(LeaderSummary, data)
            self._hand_on(self._leader)
            return
        follower = self._keys.follower_of(key, "stats")
        if follower is None:
            raise ValueError("not a follower's stats key")
        stats = typed(FollowerStats, data)
        if stats.follower != follower:
            raise ValueError(f"follower {stats.follower!r:.40} is not the key's {follower!r}")
        self._followers[follower] = stats
        self._hand_on(stats)

    def _on_deliveries(self, key: str, data: Any) -> None:
        """A batch: each good record handed on, each bad one reported."""
        if not isinstance(data, list):
            raise ValueError(f"a deliveries batch must be a JSON list, got {type(data).__name__}")
        for item in data:
            try:
                record = delivery_record(item)
            except ValueError as exc:
                self.bad_input.report(key, str(exc))
                continue
            self._hand_on(record)

    def _hand_on(self, observation: Observation) -> None:
        if self._emit is not None:
            self._emit(observation)

    def close(self) -> None:
        """Stop watching; a channel's observations kept so far can still be read."""
        self._close_channel()  # first: a Zenoh thread waiting on a full FIFO goes on
        self._watch.close()

    def __enter__(self) -> Observer:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
