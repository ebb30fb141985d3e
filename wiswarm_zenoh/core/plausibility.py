"""Whether a reply can be the polled follower's own: its stamps must be ones that
follower's clock gives (see ``clock.ClockOffsetEstimator.judge``)."""

from __future__ import annotations

from wiswarm_zenoh.core.clock import STAMP_SLACK
from wiswarm_zenoh.core.peers import Peer
from wiswarm_zenoh.core.poll_records import PollRequest
from wiswarm_zenoh.core.wire import Reply


def implausible(flight: PollRequest, peer: Peer, reply: Reply, now: float) -> str | None:
    """Why ``reply`` cannot be the polled follower's answer (its stamps no clock of
    that follower gives), or None. A poll answered only by such replies counts once
    against the clock estimate (enough of them in a row re-anchor it)."""
    reason = peer.clock.judge(flight.sent_at, reply.received_at, reply.sent_at, now,
                              reanchor=not flight.refused)
    if reason is not None:
        if not flight.refused:
            flight.refused = True
            peer.clock.refused()
        return reason
    frag = reply.fragment
    if frag is not None and frag.generated_at > reply.sent_at + STAMP_SLACK:
        return (f"update generated {frag.generated_at - reply.sent_at:.3f} s after "
                "the reply carrying it was sent")
    return None
