"""The work a valid answer brings, done by the leader once the next poll is out: its
fragment into the follower's reassembly, then a whole update's checksum, AoI and
delivery. Each step moves the poll's record on (``poll_records.Stage``)."""

from __future__ import annotations

from wiswarm_zenoh.core.clock import STAMP_SLACK
from wiswarm_zenoh.core.errors import WireError
from wiswarm_zenoh.core.events import Delivered, Event, Rejected, Stale
from wiswarm_zenoh.core.fragments import verify_checksum
from wiswarm_zenoh.core.peers import PeerTable
from wiswarm_zenoh.core.poll_records import PollLife, Stage


def take_fragment(life: PollLife) -> list[Event]:
    """Collect the answer's fragment. An update it completes waits (``UNSETTLED``),
    counted for the scheduler at once, unless its time-stamp is ahead of the reply's
    arrival by more than the clock estimate's error can be (the poll's round trip, and
    some slack): such an update is refused."""
    life.stage = Stage.DONE
    request, peer, reply, now = life.request, life.peer, life.reply, life.answered_at
    assert reply is not None
    follower, frag = request.follower, reply.fragment
    if frag is None:
        peer.idle_since = now
        peer.pace.empty(now)
        return []
    try:
        whole = peer.reassembler.add(frag)
    except WireError as exc:
        peer.errors += 1
        peer.ack, peer.want = None, "fresh"
        return [Rejected(follower, str(exc))]
    peer.ack, peer.want = (frag.update_seq, frag.index), "next"
    if whole is None:
        return []
    generated_at = peer.clock.to_leader(frag.generated_at)
    ahead = generated_at - now
    if ahead > now - request.sent_at + STAMP_SLACK:
        peer.errors += 1
        return [Rejected(follower, f"update stamped {ahead:.3f} s in the future")]
    peer.unsettled_tau = generated_at
    peer.pace.taken(frag.update_seq, frag.generated_at, generated_at)
    life.stage, life.frag, life.whole, life.generated_at = \
        Stage.UNSETTLED, frag, whole, generated_at
    return []


def settle_update(life: PollLife, table: PeerTable) -> list[Event]:
    """Checksum, AoI and delivery of an update taken whole. Its time-stamp is on the
    leader's clock as estimated when it came: a follower restarting since changes
    nothing. A failed checksum withdraws the freshness it was counted with."""
    life.stage = Stage.DONE
    follower, peer, frag, now = life.request.follower, life.peer, life.frag, life.answered_at
    assert frag is not None
    peer.unsettled_tau = float("-inf")
    try:
        verify_checksum(life.whole, frag)
    except WireError as exc:
        peer.errors += 1
        peer.ack, peer.want = None, "fresh"
        table.sync(follower)
        return [Rejected(follower, str(exc))]
    generated_at = min(life.generated_at, now)  # ahead within the tolerance: now
    delivered = peer.aoi.deliver(generated_at, now)
    table.sync(follower)
    if not delivered:
        peer.stale += 1
        return [Stale(follower, "update older than the freshest delivered")]
    return [Delivered(follower, life.whole, generated_at, now, frag.update_seq)]
