"""WiSwarm over the simulated medium: the core's own Leader and Followers in virtual time.

The leader's poll (with the control broadcast) goes out from the leader's station;
when the poll arrives, the follower answers after a host turnaround with the reply
bytes that ``Follower.on_poll`` returns, sent as one UDP datagram (IP-fragmented);
the whole reply goes to ``Leader.receive_reply``, the next poll goes out, and the
leader's events are drained, as the Zenoh shell does. A lost poll or reply fragment
leaves the leader to its timer (``get_timer`` / ``handle_timer``). Cameras sample at a fixed rate
into the LIFO queue: each follower is offered its freshest sample when it answers a
poll, which is all a LIFO of capacity 1 would keep. Frames carry their true capture
time in an 8-byte header, so AoI is measured on ground truth, not on the leader's
(NTP-style, delay-asymmetric) clock estimate.
"""

from __future__ import annotations

import math
import random
import struct
from collections.abc import Sequence
from functools import partial

from wiswarm_zenoh.core.config import FollowerConfig, LeaderConfig
from wiswarm_zenoh.core.events import Delivered
from wiswarm_zenoh.core.follower import Follower
from wiswarm_zenoh.core.leader import Leader, PollRequest
from wiswarm_zenoh.sim.channel import Channel, PacketCosts
from wiswarm_zenoh.sim.engine import Engine
from wiswarm_zenoh.sim.medium import Mpdu, Station
from wiswarm_zenoh.sim.metrics import FrameSink

STAMP = struct.Struct("<d")


def _ignore(data: object, ok: bool, now: float) -> None:
    """Outcome hook of the control broadcast: nobody consumes waypoints in these runs."""


class WiswarmNetwork:
    """A leader polling ``len(stations)`` followers over the medium."""

    def __init__(
        self,
        engine: Engine,
        medium: Channel,
        airtime: PacketCosts,
        leader_station: Station,
        stations: Sequence[Station],
        p_success: Sequence[float],
        sinks: Sequence[FrameSink],
        frame_bytes: int,
        sample_rate: float,
        host_delay: float,
        leader_config: LeaderConfig,
        follower_config: FollowerConfig,
    ) -> None:
        self._engine = engine
        self._medium = medium
        self._air = airtime
        self._leader_station = leader_station
        self._stations = list(stations)
        self._p = list(p_success)
        self._sinks = list(sinks)
        self._period = 1.0 / sample_rate
        self._phases = [engine.rng.random() * self._period for _ in stations]
        self._last_sample = [-math.inf] * len(stations)
        self._host_delay = host_delay
        self._body = bytes(frame_bytes - STAMP.size)
        self.leader = Leader(leader_config, random.Random(engine.rng.getrandbits(64)))
        self.followers = [Follower(f"uav{i}", follower_config) for i in range(len(stations))]
        self._index = {f.follower_id: i for i, f in enumerate(self.followers)}
        for follower in self.followers:
            self.leader.add_follower(follower.follower_id, 0.0)
        self._timer_version = 0
        self._lost_poll = -1  # poll_seq of the last poll or reply that lost a packet

    def start(self) -> None:
        self._engine.at(self._engine.now, self._poll)

    def cut(self, i: int) -> None:
        """Follower ``i``'s link delivers nothing from now on (the follower died)."""
        self._p[i] = 0.0

    def _send_datagram(
        self, station: Station, size: int, p: float, hook: partial[None], broadcast: bool = False
    ) -> None:
        """Queue the IP fragments of one UDP datagram; ``hook`` gets (is_last, ok, now)."""
        air = self._air
        packets = air.udp_packets(size)
        last = len(packets) - 1
        for k, ip_bytes in enumerate(packets):
            busy = air.broadcast_busy(ip_bytes) if broadcast else air.unicast_busy(ip_bytes)
            if not self._medium.send(station, Mpdu(busy, p, not broadcast, hook, k == last)):
                hook(k == last, False, self._engine.now)

    def _poll(self) -> None:
        request = self.leader.next_poll(self._engine.now)
        if request is None:  # no source due yet (or nobody to poll): wait for the timer
            wake = self.leader.get_timer()
            if wake is not None:
                self._timer_version += 1
                self._engine.at(wake, partial(self._on_timer, self._timer_version))
            return
        i = self._index[request.follower]
        leader = self._leader_station
        control = request.control
        if control is not None:
            self._send_datagram(leader, len(control), 1.0, partial(_ignore), broadcast=True)
        hook = partial(self._poll_sent, request)
        self._send_datagram(leader, len(request.payload), self._p[i], hook)
        self._timer_version += 1
        self._engine.at(request.deadline, partial(self._on_timer, self._timer_version))

    def _poll_sent(self, request: PollRequest, data: object, ok: bool, now: float) -> None:
        if not ok:
            self._lost_poll = request.poll_seq
        elif data and self._lost_poll != request.poll_seq:
            self._engine.at(now + self._host_delay, partial(self._answer, request, now))

    def _answer(self, request: PollRequest, received_at: float) -> None:
        now = self._engine.now
        i = self._index[request.follower]
        phase = self._phases[i]
        sample = phase + math.floor((now - phase) / self._period) * self._period
        follower = self.followers[i]
        if sample > self._last_sample[i]:
            self._last_sample[i] = sample
            follower.offer(STAMP.pack(sample) + self._body, sample)
        reply = follower.on_poll(request.payload, received_at, now)
        hook = partial(self._reply_sent, request, reply)
        self._send_datagram(self._stations[i], len(reply), self._p[i], hook)

    def _reply_sent(
        self, request: PollRequest, reply: bytes, data: object, ok: bool, now: float
    ) -> None:
        if not ok:
            self._lost_poll = request.poll_seq
            return
        if not data or self._lost_poll == request.poll_seq:
            return
        in_flight = self.leader.in_flight == request.follower
        self.leader.receive_reply(request.follower, reply, now)
        if in_flight and self.leader.in_flight is None:
            self._timer_version += 1
            self._poll()
        self._take_events()

    def _on_timer(self, version: int) -> None:
        if version != self._timer_version:
            return
        self.leader.handle_timer(self._engine.now)
        self._poll()
        self._take_events()

    def _take_events(self) -> None:
        """The leader's events, once the next poll is out (as a shell takes them)."""
        while (event := self.leader.next_event()) is not None:
            if isinstance(event, Delivered):
                sink = self._sinks[self._index[event.follower]]
                sink.deliver(STAMP.unpack_from(event.payload)[0], event.delivered_at)
