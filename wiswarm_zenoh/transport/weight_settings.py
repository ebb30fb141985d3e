"""Weights set without code: given at the start (``wiswarm leader --weight``,
``WeightPresets``), or put by any tool on ``wiswarm/<swarm>/<follower>/weight`` (decimal
text, e.g. ``4``) at any time; the leader takes each as the weight the application's
urgency feeds (``Leader.set_weight``).

A value that is not a number >= 0, or a follower not polled, is counted and logged with
the key it came on; the old weight stays. In a secured swarm only the leader's side may
put there (``security/acl.py``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping

import zenoh

from wiswarm_zenoh.core import Leader
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

log = logging.getLogger(__name__)
MAX_TEXT = 64  # a weight's text is short: anything longer is not one
PRESET_GRACE = 10.0  # seconds after the start by which a preset's member is looked for


def parse_weight(payload: bytes) -> float:
    """The weight in ``payload``; ValueError saying why it is not one."""
    if len(payload) > MAX_TEXT:
        raise ValueError(f"a weight is decimal text, got {len(payload)} bytes")
    try:
        weight = float(payload.decode("ascii").strip())
    except (UnicodeDecodeError, ValueError):
        raise ValueError(f"a weight is decimal text, got {payload[:MAX_TEXT]!r}") from None
    if not (math.isfinite(weight) and weight >= 0.0):
        raise ValueError(f"a weight must be a number >= 0, got {weight!r}")
    return weight


class WeightSettings:
    """Subscribes to every follower's weight key and hands each good setting to
    ``apply(follower, weight)``, which raises ValueError for a follower not polled."""

    def __init__(self, session: zenoh.Session, keys: SwarmKeys,
                 apply: Callable[[str, float], None], bad_input: BadInputLog) -> None:
        self._keys, self._apply, self._bad = keys, apply, bad_input
        self._subscriber = session.declare_subscriber(keys.all_weights, self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        follower = self._keys.follower_of(key, "weight")
        try:
            if follower is None:
                raise ValueError("not a follower's weight key")
            self._apply(follower, parse_weight(sample.payload.to_bytes()))
        except ValueError as exc:
            self._bad.report(key, f"weight not set: {exc}")

    def close(self) -> None:
        undeclare(self._subscriber)


class WeightPresets:
    """Members' weights given before they join, each taken whenever its member joins
    (again); one whose member has not joined within ``PRESET_GRACE`` s of ``now`` is
    named in one WARNING (a misspelt name would otherwise weigh nothing, silently)."""

    def __init__(self, leader: Leader, weights: Mapping[str, float], now: float) -> None:
        self._leader = leader
        for follower, weight in weights.items():
            leader.preset_weight(follower, weight)
        self._look_at = now + PRESET_GRACE if weights else math.inf
        if weights:
            log.info("weights preset: %s", ", ".join(f"{f} {w:g}" for f, w in weights.items()))

    def look(self, now: float) -> None:
        """Name, once, the presets whose member has not joined in the grace."""
        if now < self._look_at:
            return
        self._look_at = math.inf
        waiting = self._leader.members.never_joined
        if waiting:
            log.warning("weight preset for %s, but no such member joined in %g s "
                        "(members: %s): is the name right? It is applied if one joins",
                        ", ".join(waiting), PRESET_GRACE,
                        ", ".join(self._leader.followers) or "none yet")
