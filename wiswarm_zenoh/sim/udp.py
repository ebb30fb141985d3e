"""The WiFi-UDP baseline: frames pushed as single UDP datagrams, fire and forget.

The follower's application FIFO feeds a blocking socket: a frame's IP fragments enter
the MAC queue as room frees up, so nothing is dropped below the application, and a
frame is lost if any of its fragments exhausts its MAC retries (IP cannot reassemble
it). This is the paper's best UDP setting: a whole frame in one UDP packet.
"""

from __future__ import annotations

from typing import cast

from wiswarm_zenoh.sim.channel import Channel, PacketCosts
from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.medium import Mpdu, Station
from wiswarm_zenoh.sim.metrics import FrameSink
from wiswarm_zenoh.sim.push import PushFlow
from wiswarm_zenoh.sim.source import PeriodicFifo


class UdpPush(PushFlow):
    """One follower pushing its FIFO of frames to the leader over UDP."""

    def __init__(
        self,
        engine: Engine,
        medium: Channel,
        station: Station,
        fifo: PeriodicFifo,
        airtime: PacketCosts,
        frame_bytes: int,
        p_success: float,
        sink: FrameSink,
    ) -> None:
        super().__init__(engine, medium, station, fifo, p_success, sink)
        self._busy = [airtime.unicast_busy(size) for size in airtime.udp_packets(frame_bytes)]
        self._frame = -1
        self._gen = 0.0
        self._next_packet = len(self._busy)
        self._lost_frame = -1
        self._waking = False

    def start(self) -> None:
        self._pump()

    def _pump(self) -> None:
        now = self._engine.now
        last = len(self._busy) - 1
        while self._station.room() > 0:
            if self._next_packet > last:
                gen = self._fifo.pull(now)
                if gen is None:
                    self._wake_at_next_frame(now)
                    return
                self._frame += 1
                self._gen = gen
                self._next_packet = 0
            i = self._next_packet
            data = (self._frame, i == last, self._gen)
            self._medium.send(self._station, Mpdu(self._busy[i], self._p, True, self._done, data))
            self._next_packet += 1

    def _done(self, data: object, ok: bool, now: float) -> None:
        frame, last, gen = cast(tuple[int, bool, float], data)
        if not ok:
            self._lost_frame = frame
        elif last and self._lost_frame != frame:
            self._sink.deliver(gen, now)
        self._pump()

    def _wake_at_next_frame(self, now: float) -> None:
        if not self._waking:
            self._waking = True
            self._engine.at(self._fifo.next_frame_time(now), self._wake)

    def _wake(self) -> None:
        self._waking = False
        self._pump()
