"""The follower's state machine: queue updates, answer each poll with one fragment."""

from __future__ import annotations

from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES, FollowerConfig
from wiswarm_zenoh.core.control_gate import ControlGate
from wiswarm_zenoh.core.fragments import OutgoingUpdate
from wiswarm_zenoh.core.pollers import Poller, Pollers
from wiswarm_zenoh.core.queues import RateController, Update, UpdateQueue
from wiswarm_zenoh.core.wire import (
    MAX_ID_BYTES,
    Control,
    Poll,
    Waypoint,
    decode_control,
    decode_poll,
    id_fits,
    pack_reply,
    reply_prefix,
)


class Follower:
    """Sans-I/O follower (paper, Section II-D).

    ``offer`` admits application updates through rate control into the queue;
    ``on_poll`` answers with the next unacknowledged fragment of the update in progress
    to that poller, or the first fragment of the freshest queued update, or "nothing
    new"; ``on_control`` says whether a control message is to be obeyed. Each poller
    has its own transfer (see ``pollers``); control is judged by ``control_gate``.
    """

    def __init__(self, follower_id: str, config: FollowerConfig | None = None) -> None:
        if not id_fits(follower_id):
            raise ValueError(
                f"follower_id must be a non-empty string of at most {MAX_ID_BYTES} UTF-8 bytes"
            )
        self.follower_id = follower_id
        self.config = config or FollowerConfig()
        self.queue = UpdateQueue(self.config.queue, self.config.capacity, self.config.drop)
        self.rate = RateController(self.config.rate_hz) if self.config.rate_hz else None
        self.offered = 0
        self.rate_dropped = 0
        self.abandoned = 0
        self.polls = 0
        self._seq = 0
        self.pollers = Pollers(self.config.poller_expiry)
        self._taken: Update | None = None  # the last update the main poller took
        self.control = ControlGate(self.pollers, self.config.control_window)
        self._chunk = self.config.fragment_size - FRAGMENT_HEADER_BYTES  # payload bytes
        self._reply_prefix = reply_prefix(follower_id)

    def offer(self, payload: bytes | bytearray | memoryview, now: float) -> bool:
        """Time-stamp an update with ``now`` and queue it; False if it was dropped."""
        if type(payload) is bytes:
            data = payload
        elif isinstance(payload, bytes | bytearray | memoryview):
            data = bytes(payload)
        else:
            raise TypeError(f"payload must be bytes, got {type(payload).__name__}")
        if len(data) > self.config.max_update_bytes:
            raise ValueError(
                f"update of {len(data)} bytes exceeds max_update_bytes "
                f"({self.config.max_update_bytes})"
            )
        self.offered += 1
        if self.rate is not None and not self.rate.admit(now):
            self.rate_dropped += 1
            return False
        self._seq += 1
        return self.queue.push(Update(self._seq, now, data))

    def on_poll(self, data: object, received_at: float, now: float) -> bytes:
        """Answer one poll (raises ``WireError`` if ``data`` is not a poll)."""
        poll = decode_poll(data)
        self.polls += 1
        poller = self.pollers.heard(poll.epoch, poll.leader_time, received_at)
        if poller.sending is not None:
            self._apply_ack(poller, poll)
        outgoing = self._current(poller)
        return pack_reply(self._reply_prefix, poll.seq, received_at, now,
                          None if outgoing is None else outgoing.fragment())

    def _apply_ack(self, poller: Poller, poll: Poll) -> None:
        sending = poller.sending
        assert sending is not None
        if poll.want == "fresh":
            # The leader lost what it had of this update: start it over (the abandon
            # rule may still switch to a fresher one). Never drop it unsent.
            sending.next_index = 0
            return
        if poll.ack is not None:
            sending.acknowledge(*poll.ack)
        if sending.done:
            poller.sending = None

    def _current(self, poller: Poller) -> OutgoingUpdate | None:
        """The update to send ``poller`` from now on, switching to a fresher one by the
        abandon rule. The main poller takes updates from the queue; any other is sent
        the freshest update there is, if it has not had it yet."""
        main = poller is self.pollers.main
        waiting = self.queue.peek() if main else self._freshest_for(poller)
        sending = poller.sending
        if sending is not None and waiting is not None and self._should_abandon(sending,
                                                                                 waiting):
            self.abandoned += 1
            sending = None
        if sending is None:
            update = self.queue.pop() if main else waiting
            if update is None:
                poller.sending = None
                return None
            if main:
                self._taken = update
            sending = OutgoingUpdate(update, self._chunk)
            poller.last_seq = update.seq
        poller.sending = sending
        return sending

    def _freshest_for(self, poller: Poller) -> Update | None:
        """The freshest update queued or taken by the main poller, if newer than the last
        one ``poller`` was sent."""
        fresh = [u for u in (self.queue.peek(), self._taken)
                 if u is not None and u.seq > poller.last_seq]
        return max(fresh, key=lambda u: u.generated_at, default=None)

    def _should_abandon(self, sending: OutgoingUpdate, waiting: Update) -> bool:
        if self.config.queue == "fifo" or waiting.generated_at <= sending.update.generated_at:
            return False
        nothing_acked = sending.next_index == 0
        age_gap = waiting.generated_at - sending.update.generated_at
        return nothing_acked or age_gap > self.config.abandon_after

    def on_control(self, data: bytes, now: float) -> list[Waypoint] | None:
        """This follower's waypoints from a control message to obey (see
        ``control_gate``), or None (not newer, or nothing for this follower).

        Raises ``WireError`` on malformed bytes and on a leader time outside the window.
        """
        return self.take_control(decode_control(data), now)

    def take_control(self, control: Control, now: float) -> list[Waypoint] | None:
        """``on_control`` for a message decoded already (once for all the followers a
        process hosts)."""
        if not self.control.admit(control, now):
            return None
        entry = control.entries.get(self.follower_id)
        return None if entry is None else list(entry)
