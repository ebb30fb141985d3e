"""The follower's state machine: queue updates, answer each poll with one fragment."""

from __future__ import annotations

from wiswarm_zenoh.core.config import FRAGMENT_HEADER_BYTES, FollowerConfig
from wiswarm_zenoh.core.fragments import OutgoingUpdate
from wiswarm_zenoh.core.queues import RateController, Update, UpdateQueue
from wiswarm_zenoh.core.wire import (
    MAX_ID_BYTES,
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
    ``on_poll`` answers with the next unacknowledged fragment of the update in progress,
    or the first fragment of the freshest queued update, or "nothing new".
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
        self._sending: OutgoingUpdate | None = None
        self._control_key: tuple[float, int] | None = None
        self._chunk = self.config.fragment_size - FRAGMENT_HEADER_BYTES  # payload bytes
        self._reply_prefix = reply_prefix(follower_id)

    def offer(self, payload: bytes, now: float) -> bool:
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

    def on_poll(self, data: bytes, received_at: float, now: float) -> bytes:
        """Answer one poll (raises ``WireError`` if ``data`` is not a poll)."""
        poll = decode_poll(data)
        self.polls += 1
        if self._sending is not None:
            self._apply_ack(self._sending, poll)
        outgoing = self._current()
        return pack_reply(self._reply_prefix, poll.seq, received_at, now,
                          None if outgoing is None else outgoing.fragment())

    def _apply_ack(self, sending: OutgoingUpdate, poll: Poll) -> None:
        if poll.want == "fresh":
            # The leader lost what it had of this update: start it over (the abandon
            # rule may still switch to a fresher one). Never drop it unsent.
            sending.next_index = 0
            return
        if poll.ack is not None:
            sending.acknowledge(*poll.ack)
        if sending.done:
            self._sending = None

    def _current(self) -> OutgoingUpdate | None:
        """The update to send from now on, switching to a fresher one by the abandon rule."""
        sending = self._sending
        if sending is not None:
            waiting = self.queue.peek()
            if waiting is not None and self._should_abandon(sending, waiting):
                self.abandoned += 1
                sending = None
        if sending is None:
            update = self.queue.pop()
            if update is None:
                self._sending = None
                return None
            sending = OutgoingUpdate(update, self._chunk)
        self._sending = sending
        return sending

    def _should_abandon(self, sending: OutgoingUpdate, waiting: Update) -> bool:
        if self.config.queue == "fifo" or waiting.generated_at <= sending.update.generated_at:
            return False
        nothing_acked = sending.next_index == 0
        age_gap = waiting.generated_at - sending.update.generated_at
        return nothing_acked or age_gap > self.config.abandon_after

    def on_control(self, data: bytes) -> list[Waypoint] | None:
        """This follower's waypoints from a control message newer than any seen before.

        Raises ``WireError`` on malformed bytes. Newer means a later (leader time, seq):
        leader time first, so a restarted leader (seq back at 0) is still obeyed.
        """
        control = decode_control(data)
        key = (control.leader_time, control.seq)
        if self._control_key is not None and key <= self._control_key:
            return None
        self._control_key = key
        entry = control.entries.get(self.follower_id)
        return None if entry is None else list(entry)
