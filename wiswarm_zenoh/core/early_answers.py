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

from wiswarm_zenoh.core.fixed_layout import peek_update
from wiswarm_zenoh.core.peers import PeerTable
from wiswarm_zenoh.core.poll_records import Flight, Pick
from wiswarm_zenoh.core.scheduling import holds_on_answer


def answer_decides(pick: Pick, flight: Flight, table: PeerTable, data: object,
                   now: float) -> bool:
    """Whether the reply ``data`` to ``flight`` (the one poll out, the pick made for
    after it) leaves ``pick`` to be polled next: by its header, it answers that poll with
    a whole update, and the polled follower's index as that update leaves its row does
    not beat the pick. Only the header is read: where the next poll waits on this, the
    leader's state is cold in the caches, and reading the reply whole took as long as
    all the rest (the judging reads it whole, after the poll went). Near the pick's
    bound (``Pick.holds_from``) the polled follower's new index is weighed."""
    header = peek_update(data, flight.request.follower) if type(data) is bytes else None
    if header is None:
        return False
    poll_seq, generated_at, count = header
    if poll_seq != pick.poll_seq or count != 1:
        return False
    if generated_at >= pick.fresh_from and pick.holds_from <= now <= pick.at + pick.slot \
            and not table.disturbed:
        return True  # fresh enough by the bound made with the pick: no index to compute
    peer = flight.peer
    return holds_on_answer(pick, table, min(peer.clock.to_leader(generated_at), now),
                           peer.reliability.after(True), now)
