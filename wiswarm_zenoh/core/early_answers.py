"""The next poll before a reply is judged, where the reply alone decides whom to poll.

Judging a reply (its clock stamps, reassembly, checksum, AoI, estimators) is most of
the leader's Python per poll, and while it runs no poll is out: the channel idles. With
one poll out, the pick for after it is made while its reply is on the way
(``scheduling.pick_after``); what the reply can still change is only the polled
follower's own index. Read from the reply's header (a whole update, stamped at its
generation time), that index is known before any judging, and where it does not beat
the pick, the next poll goes out at once and the reply is judged while it travels.

Where the judging then disagrees (the update was stale or damaged, or its clock sample
moved the estimate past the pick), that poll went to the second best follower; a reply
refused as not the follower's leaves its poll out beside the new one until it ends.
"""

from __future__ import annotations

from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.peers import PeerTable
from wiswarm_zenoh.core.poll_records import Flight, Pick
from wiswarm_zenoh.core.scheduling import holds_on_answer
from wiswarm_zenoh.core.wire import Reply, decode_reply


class EarlyAnswers:
    """Replies read ahead of their judging, and how often the next poll went out first."""

    def __init__(self) -> None:
        self.polls = 0  # polls sent before the reply before them was judged
        self._data: object = None  # the reply read last: its bytes, as read,
        self._reply: Reply | None = None  # and what they hold

    def decides(self, pick: Pick, flight: Flight, table: PeerTable, data: object,
                now: float) -> bool:
        """Whether the reply ``data`` to ``flight`` (the one poll out, the pick made
        for after it) leaves ``pick`` to be polled next: it is a whole update, and the
        polled follower's index as that update leaves its row does not beat the pick.
        The reply read is kept for ``reply``."""
        follower = flight.request.follower
        self._data = data
        try:
            self._reply = reply = decode_reply(data, follower)
        except WireError:
            self._reply = None
            return False  # (refused when judged)
        frag, peer = reply.fragment, flight.peer
        if frag is None or frag.count != 1 or reply.poll_seq != pick.poll_seq \
                or reply.follower != follower:
            return False
        if not holds_on_answer(pick, table, min(peer.clock.to_leader(frag.generated_at), now),
                               peer.reliability.after(True), now):
            return False
        self.polls += 1
        return True

    def reply(self, data: object, follower: str) -> Reply:
        """The reply in ``data``: as read ahead, if it was, else decoded now
        (``WireError`` if it is not one)."""
        reply = self._reply
        if reply is not None and self._data is data:
            return reply
        return decode_reply(data, follower)
