"""What every push baseline flow holds, so UDP and TCP flows share one constructor core."""

from __future__ import annotations

from wiswarm_zenoh.sim.channel import Channel
from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.medium import Station
from wiswarm_zenoh.sim.metrics import FrameSink
from wiswarm_zenoh.sim.source import PeriodicFifo


class PushFlow:
    """A follower's camera FIFO pushed from its station over the medium to the leader's
    frame sink, each MAC attempt succeeding with probability ``p_success``."""

    def __init__(self, engine: Engine, medium: Channel, station: Station, fifo: PeriodicFifo,
                 p_success: float, sink: FrameSink) -> None:
        self._engine = engine
        self._medium = medium
        self._station = station
        self._fifo = fifo
        self._p = p_success
        self._sink = sink
