"""The WiFi-TCP baseline: frames over one reliable TCP connection per follower.

A compact NewReno: initial window 10, slow start and congestion avoidance (growing
only while cwnd-limited), fast retransmit after three duplicate ACKs, partial-ACK
retransmission, and an RFC 6298 retransmission timer (200 ms floor, as Linux). The
receiver at the leader ACKs every second in-order segment at once (40 ms delayed-ACK
timer otherwise) and every out-of-order segment; ACKs are MAC frames from the leader's
station and contend for the medium like any data. Frames start on a segment boundary
and are handed to the application when all their bytes have arrived in order.

A small send buffer (``send_buffer``, newest only) bounds the bytes written and not yet
acknowledged: the window is at most what it holds, and the application writes its next
frame the moment the previous one is all in it (its blocking send returned), taking the
newest from its camera's slot; the kernel's own buffer (None) never binds here.
"""

from __future__ import annotations

from collections import deque
from functools import partial
from typing import cast

from wiswarm_zenoh.sim.channel import Channel, PacketCosts
from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.medium import Mpdu, Station
from wiswarm_zenoh.sim.metrics import FrameSink
from wiswarm_zenoh.sim.phy import IP_HEADER, TCP_HEADER
from wiswarm_zenoh.sim.push import PushFlow
from wiswarm_zenoh.sim.source import PeriodicFifo

INITIAL_WINDOW = 10
RTO_INITIAL = 1.0
RTO_MIN = 0.2
RTO_MAX = 60.0
DELAYED_ACK = 0.04


class TcpFlow(PushFlow):
    """One follower's connection: the sender at its station, the receiver at the leader."""

    def __init__(
        self,
        engine: Engine,
        medium: Channel,
        station: Station,
        leader: Station,
        fifo: PeriodicFifo,
        airtime: PacketCosts,
        frame_bytes: int,
        p_success: float,
        sink: FrameSink,
        send_buffer: int | None = None,
    ) -> None:
        super().__init__(engine, medium, station, fifo, p_success, sink)
        self._leader = leader
        mss = airtime.tcp_mss
        self._buffer = None if send_buffer is None else max(send_buffer // mss, 1)  # segments
        self._frame_segments = -(-frame_bytes // mss)
        last = frame_bytes - (self._frame_segments - 1) * mss
        self._busy_full = airtime.unicast_busy(mss + IP_HEADER + TCP_HEADER)
        self._busy_last = airtime.unicast_busy(last + IP_HEADER + TCP_HEADER)
        self._busy_ack = airtime.unicast_busy(IP_HEADER + TCP_HEADER)
        # Sender.
        self._una = 0
        self._nxt = 0
        self._high = 0  # one past the highest segment ever sent
        self._stream_end = 0
        self._frames: deque[tuple[int, float]] = deque()  # (end segment, generation time)
        self._cwnd = float(INITIAL_WINDOW)
        self._ssthresh = float("inf")
        self._dupacks = 0
        self._recover = -1  # in fast recovery while una < recover
        self._retransmit = False
        self._timed: tuple[int, float] | None = None
        self._srtt: float | None = None
        self._rttvar = 0.0
        self._rto = RTO_INITIAL
        self._rto_version = 0
        self._rto_armed = False
        self._waking = False
        # Receiver.
        self._rcv_nxt = 0
        self._out_of_order: set[int] = set()
        self._unacked = 0
        self._delack_version = 0
        self.retransmissions = 0
        self.timeouts = 0

    def start(self) -> None:
        self._pump()

    # ---- sender -------------------------------------------------------------------
    def _pump(self) -> None:
        now = self._engine.now
        if self._buffer is not None:
            self._write(now, self._buffer)
        while self._station.room() > 0:
            if self._retransmit:
                self._retransmit = False
                self._send_segment(self._una, now)
                continue
            if self._nxt - self._una >= self._window():
                return
            if self._nxt == self._stream_end and not self._pull_frame(now):
                return
            self._send_segment(self._nxt, now)
            self._nxt += 1
            self._high = max(self._high, self._nxt)

    def _window(self) -> int:
        cwnd = int(self._cwnd)
        return cwnd if self._buffer is None else min(cwnd, self._buffer)

    def _write(self, now: float, buffer: int) -> None:
        """The application's blocking sends into a send buffer of ``buffer`` segments:
        the next frame goes in once what was written before fits."""
        while self._stream_end - self._una <= buffer:
            if not self._pull_frame(now):
                return

    def _pull_frame(self, now: float) -> bool:
        gen = self._fifo.pull(now)
        if gen is None:
            if not self._waking:
                self._waking = True
                self._engine.at(self._fifo.next_frame_time(now), self._wake)
            return False
        self._stream_end += self._frame_segments
        self._frames.append((self._stream_end, gen))
        return True

    def _wake(self) -> None:
        self._waking = False
        self._pump()

    def _send_segment(self, seg: int, now: float) -> None:
        last_of_frame = (seg + 1) % self._frame_segments == 0
        busy = self._busy_last if last_of_frame else self._busy_full
        if seg < self._high:
            self.retransmissions += 1
            self._timed = None  # Karn: no RTT sample across a retransmission
        elif self._timed is None:
            self._timed = (seg, now)
        self._medium.send(self._station, Mpdu(busy, self._p, True, self._data_done, seg))
        if not self._rto_armed:
            self._arm_rto(now)

    def _data_done(self, data: object, ok: bool, now: float) -> None:
        if ok:
            self._receive(cast(int, data), now)
        self._pump()

    def _ack_done(self, data: object, ok: bool, now: float) -> None:
        if not ok:
            return
        ack = cast(int, data)
        if ack > self._una:
            self._new_ack(ack, now)
        elif ack == self._una and self._nxt > self._una:
            self._dupacks += 1
            if self._dupacks == 3 and self._una >= self._recover:
                self._ssthresh = max((self._nxt - self._una) / 2, 2.0)
                self._cwnd = self._ssthresh
                self._recover = self._nxt
                self._retransmit = True
        self._pump()

    def _new_ack(self, ack: int, now: float) -> None:
        acked = ack - self._una
        cwnd_limited = self._nxt - self._una >= int(self._cwnd)
        if self._timed is not None and ack > self._timed[0]:
            self._rtt_sample(now - self._timed[1])
            self._timed = None
        self._una = ack
        self._nxt = max(self._nxt, ack)
        self._dupacks = 0
        if ack < self._recover:
            self._retransmit = True  # partial ACK: the next hole is lost too
        elif cwnd_limited:
            if self._cwnd < self._ssthresh:
                self._cwnd += min(acked, 2)
            else:
                self._cwnd += acked / self._cwnd
        if self._una < self._nxt:
            self._arm_rto(now)
        else:
            self._rto_armed = False
            self._rto_version += 1

    def _rtt_sample(self, rtt: float) -> None:
        if self._srtt is None:
            self._srtt, self._rttvar = rtt, rtt / 2
        else:
            self._rttvar = 0.75 * self._rttvar + 0.25 * abs(self._srtt - rtt)
            self._srtt = 0.875 * self._srtt + 0.125 * rtt
        self._rto = min(max(self._srtt + 4 * self._rttvar, RTO_MIN), RTO_MAX)

    def _arm_rto(self, now: float) -> None:
        self._rto_armed = True
        self._rto_version += 1
        self._engine.at(now + self._rto, partial(self._on_rto, self._rto_version))

    def _on_rto(self, version: int) -> None:
        if version != self._rto_version:
            return
        self.timeouts += 1
        self._ssthresh = max((self._nxt - self._una) / 2, 2.0)
        self._cwnd = 1.0
        self._nxt = self._una
        self._recover = -1
        self._dupacks = 0
        self._retransmit = False
        self._rto = min(2 * self._rto, RTO_MAX)
        self._rto_armed = False
        self._pump()

    # ---- receiver (at the leader) -----------------------------------------------------
    def _receive(self, seg: int, now: float) -> None:
        if seg == self._rcv_nxt:
            filled_hole = bool(self._out_of_order)
            self._rcv_nxt += 1
            while self._rcv_nxt in self._out_of_order:
                self._out_of_order.remove(self._rcv_nxt)
                self._rcv_nxt += 1
            frames = self._frames
            while frames and frames[0][0] <= self._rcv_nxt:
                self._sink.deliver(frames.popleft()[1], now)
            self._unacked += 1
            if filled_hole or self._unacked >= 2:
                self._send_ack()
            elif self._unacked == 1:
                self._delack_version += 1
                self._engine.at(now + DELAYED_ACK, partial(self._delayed_ack, self._delack_version))
        else:
            if seg > self._rcv_nxt:
                self._out_of_order.add(seg)
            self._send_ack()

    def _delayed_ack(self, version: int) -> None:
        if version == self._delack_version and self._unacked:
            self._send_ack()

    def _send_ack(self) -> None:
        self._unacked = 0
        self._delack_version += 1
        mpdu = Mpdu(self._busy_ack, self._p, True, self._ack_done, self._rcv_nxt)
        self._medium.send(self._leader, mpdu)
