"""The tracking app's side of the push baseline; the baseline itself is the middleware's
(``wiswarm_zenoh.baselines``). Each UAV puts its frames with the middleware's
``PushSender`` (a FIFO drained in order, reliable delivery, so a congested path builds
the FIFO up, as in the paper); the leader takes them from the middleware's ``Receiver``
(which measures and publishes the baseline's stats) into the app's ``Reception``, and
sends the plans on the control key with the wire format of the polling system, when they
change and every ``control_period``. AoI comes from the generation time every frame
carries (the UAVs' and leader's clocks are taken as one: there is no poll to estimate an
offset from).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack

import zenoh

from apps.tracking.reception import Reception
from wiswarm_zenoh.baselines import Receiver
from wiswarm_zenoh.core import Control, Waypoint, encode_control, validate_waypoints
from wiswarm_zenoh.transport import SwarmKeys

log = logging.getLogger(__name__)

CONTROL_PERIOD = 0.1


class PushLeader:
    """Leader side: pushed frames into `reception` (through the middleware's receiver,
    which also publishes the baseline's stats); a ControlSink for plans."""

    def __init__(self, session: zenoh.Session, swarm: str, reception: Reception,
                 control_period: float = CONTROL_PERIOD,
                 clock: Callable[[], float] = time.time) -> None:
        self.keys = SwarmKeys(swarm)
        self._clock = clock
        self._period = control_period
        self._entries: dict[str, list[Waypoint]] = {}
        self._weights: dict[str, float] = {}
        self._seq = 0
        self._epoch = max(0, int(clock() * 1e6))  # as a polling leader's: its start time
        self._lock = threading.Lock()
        self._changed = threading.Event()
        self._stop = threading.Event()
        self._entities = ExitStack()
        self._control = self._entities.enter_context(
            session.declare_publisher(self.keys.control, express=True)
        )
        receiver = self._entities.enter_context(
            Receiver(session, swarm, "push", on_frame=reception.receive, clock=clock))
        self.bad_input = receiver.bad_input
        self._thread = threading.Thread(target=self._run, name="push-control", daemon=True)
        self._thread.start()

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        checked = validate_waypoints(waypoints)
        with self._lock:
            self._entries[follower] = checked
        self._changed.set()

    def observe_urgency(self, follower: str, v: float) -> None:
        """Nothing is scheduled here: the urgency is only kept for display."""
        with self._lock:
            self._weights[follower] = v

    def weights(self) -> dict[str, float]:
        with self._lock:
            return dict(self._weights)

    def _run(self) -> None:
        while not self._stop.is_set():
            self._changed.wait(self._period)
            self._changed.clear()
            with self._lock:
                entries = dict(self._entries)
            if entries and not self._stop.is_set():
                self._seq += 1
                self._control.put(encode_control(
                    Control(self._seq, self._clock(), entries, self._epoch)))

    def close(self) -> None:
        self._stop.set()
        self._changed.set()
        self._thread.join()
        self._entities.close()
