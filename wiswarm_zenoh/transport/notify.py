"""Calls into the application from a leader's threads: a callback that fails is logged,
never the end of polling."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TypeVar

log = logging.getLogger("wiswarm_zenoh.transport.leader_node")
T = TypeVar("T")


def notify(callback: Callable[[T], object], arg: T) -> None:
    """Run an application callback; its failure is logged, never the end of polling."""
    try:
        callback(arg)
    except Exception:
        log.exception("callback %r failed on %r", callback, arg)
