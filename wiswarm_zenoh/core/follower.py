"""The follower's state machine: queue updates, answer each poll with one fragment."""

from __future__ import annotations

from wiswarm_zenoh.core.config import FollowerConfig
from wiswarm_zenoh.core.fragments import OutgoingUpdate
from wiswarm_zenoh.core.queues import RateController, Update, UpdateQueue
from wiswarm_zenoh.core.wire import (
    MAX_ID_BYTES,
    Poll,
    Reply,
    Waypoint,
    decode_control,
    decode_poll,
    encode_reply,
    id_fits,
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

    def offer(self, payload: bytes, now: float) -> bool:
        """Time-stamp an update with ``now`` and queue it; False if it was dropped."""
        if not isinstance(payload, bytes | bytearray | memoryview):
            raise TypeError(f"payload must be bytes, got {type(payload).__name__}")
        data = bytes(payload)
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
        return self.queue.push(Update(seq=self._seq, generated_at=now, payload=data))

    def on_poll(self, data: bytes, received_at: float, now: float) -> bytes:
        """Answer one poll (raises ``WireError`` if ``data`` is not a poll)."""
        poll = decode_poll(data)
        self.polls += 1
        self._apply_ack(poll)
        outgoing = self._current()
        reply = Reply(
            follower=self.follower_id, poll_seq=poll.seq, received_at=received_at,
            sent_at=now, fragment=None if outgoing is None else outgoing.fragment(),
        )
        return encode_reply(reply)

    def _apply_ack(self, poll: Poll) -> None:
        sending = self._sending
        if sending is None:
            return
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
        waiting = self.queue.peek()
        sending = self._sending
        if sending is not None and waiting is not None and self._should_abandon(sending, waiting):
            self.abandoned += 1
            sending = None
        if sending is None:
            update = self.queue.pop()
            if update is None:
                self._sending = None
                return None
            sending = OutgoingUpdate.for_fragment_size(update, self.config.fragment_size)
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
