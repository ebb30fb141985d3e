"""Weights set without code: any tool puts a follower's application weight on
``wiswarm/<swarm>/<follower>/weight`` (decimal text, e.g. ``4``), and the leader takes
it as the weight the application's urgency feeds (``Leader.set_weight``).

A value that is not a number >= 0, or a follower not polled, is counted and logged with
the key it came on; the old weight stays. In a secured swarm only the leader's side may
put there (``security/acl.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import zenoh

from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.keys import SwarmKeys

MAX_TEXT = 64  # a weight's text is short: anything longer is not one


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
