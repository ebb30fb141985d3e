"""The mission's operator at the ground: puts the mission's weights on the leader's
weight keys at their times, as any tool of the leader's side would
(``transport/weight_settings``)."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from wiswarm_zenoh.programs.runners import ReadySignal, StopSignal, wait_until_stopped
from wiswarm_zenoh.transport.zenoh_config import SessionSpec

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class OperatorOptions:
    """(wall-clock time, key, text) to put, in order."""

    puts: tuple[tuple[float, str, str], ...]


def run_operator(spec: SessionSpec, options: OperatorOptions, stop: StopSignal,
                 ready: ReadySignal | None = None) -> None:
    """Each put at its time, then idle until stopped."""
    with spec.open() as session:
        if ready is not None:
            ready.set()
        for at, key, text in options.puts:
            if stop.wait(max(0.0, at - time.time())):
                return
            session.put(key, text)
            log.info("operator: %s = %s", key, text)
        wait_until_stopped(stop)
