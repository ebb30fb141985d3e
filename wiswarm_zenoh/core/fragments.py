"""Splitting updates into fragments and putting them back together at the leader."""

from __future__ import annotations

from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.queues import Update
from wiswarm_zenoh.core.wire import FragmentData, checksum

__all__ = ["OutgoingUpdate", "Reassembler", "checksum", "verify_checksum"]


class OutgoingUpdate:
    """An update being sent fragment by fragment; ``next_index`` is the first unacked one.

    Stop-and-wait: one fragment per poll, resent until the leader's next poll acks it.
    (A plain class: one is made for every update sent, often one per poll.)
    """

    __slots__ = ("chunk", "count", "next_index", "update")

    def __init__(self, update: Update, chunk: int, next_index: int = 0) -> None:
        self.update = update
        self.chunk = chunk
        self.next_index = next_index
        self.count = max(1, -(-len(update.payload) // chunk))

    @property
    def done(self) -> bool:
        return self.next_index >= self.count

    def acknowledge(self, update_seq: int, index: int) -> None:
        """Advance past the fragment the leader says it received (others are ignored)."""
        if update_seq == self.update.seq and index == self.next_index:
            self.next_index += 1

    def fragment(self) -> FragmentData:
        update, index, chunk = self.update, self.next_index, self.chunk
        payload = update.payload
        data = payload if self.count == 1 else payload[index * chunk:(index + 1) * chunk]
        return FragmentData(update.seq, update.generated_at, index, self.count, len(payload),
                            update.checksum, data)


class Reassembler:
    """Collects one follower's fragments of its current update and checks the whole.

    A fragment of a different update starts over (the follower abandoned the old one or
    restarted); duplicates are ignored; a mismatch of count or size raises ``WireError``
    and drops what was collected. The whole update's checksum is ``verify_checksum``'s
    job: a leader runs it once the next poll is on its way.
    """

    def __init__(self, max_fragments: int, max_update_bytes: int) -> None:
        self.max_fragments = max_fragments
        self.max_update_bytes = max_update_bytes
        self._key: tuple[int, int, int, float] | None = None
        self._parts: dict[int, bytes] = {}
        self._size = 0

    def reset(self) -> None:
        self._key = None
        self._parts = {}
        self._size = 0

    def add(self, frag: FragmentData) -> bytes | None:
        """Store a fragment; return the whole update (its checksum not yet verified)
        once every fragment is in."""
        if frag.count > self.max_fragments:
            raise WireError(f"{frag.count} fragments exceed the limit of {self.max_fragments}")
        if frag.total_size > self.max_update_bytes:
            raise WireError(
                f"update of {frag.total_size} bytes exceeds the limit of {self.max_update_bytes}"
            )
        if frag.count == 1:  # the whole update in one piece: nothing to collect
            if self._key is not None:
                self.reset()
            return _sized(frag.data, frag)
        key = (frag.update_seq, frag.count, frag.checksum, frag.generated_at)
        if key != self._key:
            self.reset()
            self._key = key
        if frag.index in self._parts:
            return None
        if self._size + len(frag.data) > frag.total_size:
            self.reset()
            raise WireError("fragments add up to more than the update's size")
        self._parts[frag.index] = frag.data
        self._size += len(frag.data)
        if len(self._parts) < frag.count:
            return None
        whole = b"".join(self._parts[i] for i in range(frag.count))
        self.reset()
        return _sized(whole, frag)


def _sized(whole: bytes, frag: FragmentData) -> bytes:
    """The reassembled update, if its size matches what the fragments say."""
    if len(whole) != frag.total_size:
        raise WireError(f"reassembled {len(whole)} bytes, expected {frag.total_size}")
    return whole


def verify_checksum(whole: bytes, frag: FragmentData) -> None:
    """Raise ``WireError`` unless ``whole`` has the checksum its fragments carry."""
    if checksum(whole) != frag.checksum:
        raise WireError("checksum mismatch on the reassembled update")
