"""The push baseline (the paper's WiFi-TCP/UDP systems, over Zenoh): each UAV takes
frames at a fixed rate into a FIFO queue and a sender thread `put`s them, in order, on
``wiswarm/<swarm>/<uav>/push``; nobody schedules who talks. The sender blocks while
Zenoh's buffers are full (reliable delivery, like TCP), so a congested path builds the
FIFO up, as in the paper; a full FIFO drops the new frame (tail drop).

The leader subscribes to every UAV's push key, measures AoI from the generation time
carried in the attachment (the UAVs' and leader's clocks are taken as one: there is no
poll to estimate an offset from), and sends the plans on the control key with the
wire format of the polling system, when they change and every `control_period`.
"""

from __future__ import annotations

import logging
import math
import queue
import struct
import threading
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack

import zenoh

from apps.tracking.reception import Reception
from wiswarm_zenoh.core import Waypoint
from wiswarm_zenoh.core.wire import Control, encode_control, validate_waypoints
from wiswarm_zenoh.transport.badinput import BadInputLog
from wiswarm_zenoh.transport.keys import SwarmKeys

log = logging.getLogger(__name__)

PUSH_LEAF = "push"
STAMP = struct.Struct("<dQ")  # generation time (UAV clock), frame sequence number
CONTROL_PERIOD = 0.1


def push_key(keys: SwarmKeys, uav: str) -> str:
    return f"{keys.prefix}/{uav}/{PUSH_LEAF}"


class PushSender:
    """UAV side: `offer` queues a frame; the sender thread puts the queue out in order,
    each frame with its generation time and sequence number as the attachment."""

    def __init__(self, session: zenoh.Session, swarm: str, uav: str, capacity: int = 64,
                 clock: Callable[[], float] = time.time) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.key = push_key(SwarmKeys(swarm), uav)
        self.offered = 0
        self.dropped = 0
        self.sent = 0
        self._clock = clock
        self._fifo: queue.Queue[tuple[bytes, float, int] | None] = queue.Queue(capacity)
        self._entities = ExitStack()  # zenoh entities are undeclared on exit
        self._publisher = self._entities.enter_context(session.declare_publisher(
            self.key, congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        ))
        self._thread = threading.Thread(target=self._run, name=f"push-{uav}", daemon=True)
        self._thread.start()

    def offer(self, payload: bytes) -> bool:
        """Queue a frame stamped now (as a FollowerNode stamps its updates); False if the
        FIFO is full."""
        self.offered += 1
        try:
            self._fifo.put_nowait((payload, self._clock(), self.offered))
        except queue.Full:
            self.dropped += 1
            return False
        return True

    def _run(self) -> None:
        while (item := self._fifo.get()) is not None:
            payload, generated_at, seq = item
            self._publisher.put(payload, attachment=STAMP.pack(generated_at, seq))
            self.sent += 1

    def close(self) -> None:
        """Stop after the frames already queued (the sentinel goes in behind them)."""
        self._fifo.put(None)
        self._thread.join()
        self._entities.close()


class PushLeader:
    """Leader side: receives pushed frames into `reception`; a ControlSink for plans."""

    def __init__(self, session: zenoh.Session, swarm: str, reception: Reception,
                 control_period: float = CONTROL_PERIOD,
                 clock: Callable[[], float] = time.time) -> None:
        self.keys = SwarmKeys(swarm)
        self._reception = reception
        self._clock = clock
        self._period = control_period
        self._entries: dict[str, list[Waypoint]] = {}
        self._weights: dict[str, float] = {}
        self._seq = 0
        self._lock = threading.Lock()
        self._changed = threading.Event()
        self._stop = threading.Event()
        self.bad_input = BadInputLog(log)
        self._entities = ExitStack()
        self._control = self._entities.enter_context(
            session.declare_publisher(self.keys.control, express=True)
        )
        self._entities.enter_context(
            session.declare_subscriber(f"{self.keys.prefix}/*/{PUSH_LEAF}", self._on_frame)
        )
        self._thread = threading.Thread(target=self._run, name="push-control", daemon=True)
        self._thread.start()

    def set_control(self, follower: str, waypoints: Sequence[Sequence[float]]) -> None:
        checked = validate_waypoints(waypoints)
        with self._lock:
            self._entries[follower] = checked
        self._changed.set()

    def observe_urgency(self, follower: str, v: float) -> float:
        """Nothing is scheduled here: the urgency is only kept for display."""
        with self._lock:
            self._weights[follower] = v
        return v

    def weights(self) -> dict[str, float]:
        with self._lock:
            return dict(self._weights)

    def _on_frame(self, sample: zenoh.Sample) -> None:
        now = self._clock()
        key = str(sample.key_expr)
        uav = self.keys.follower_of(key, PUSH_LEAF)
        attachment = sample.attachment
        stamp = b"" if attachment is None else attachment.to_bytes()
        if uav is None or len(stamp) != STAMP.size:
            self.bad_input.report(key, "not a push frame (bad key or missing stamp)")
            return
        generated_at, _seq = STAMP.unpack(stamp)
        if not math.isfinite(generated_at):
            self.bad_input.report(key, f"generation time {generated_at!r} is not finite")
            return
        self._reception.receive(uav, sample.payload.to_bytes(), generated_at, now)

    def _run(self) -> None:
        while not self._stop.is_set():
            self._changed.wait(self._period)
            self._changed.clear()
            with self._lock:
                entries = dict(self._entries)
            if entries and not self._stop.is_set():
                self._seq += 1
                self._control.put(encode_control(Control(self._seq, self._clock(), entries)))

    def close(self) -> None:
        self._stop.set()
        self._changed.set()
        self._thread.join()
        self._entities.close()
