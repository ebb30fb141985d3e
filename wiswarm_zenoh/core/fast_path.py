"""Whether the pick made while a poll was out still holds when its reply comes: then the
next poll goes at once, with no pass over the table (``Leader.fast_polls``)."""

from __future__ import annotations

from wiswarm_zenoh.core.peers import PeerTable
from wiswarm_zenoh.core.poll_records import Pick, PollLife
from wiswarm_zenoh.core.site_links import SiteLinks


def quick_choice(pick: Pick, life: PollLife, table: PeerTable, site_links: SiteLinks,
                 slot: float, pacing: bool, now: float) -> int | None:
    """``pick.choice`` if ``life``'s reply (the only one waiting) came as expected and the
    polled follower's new index (clock offset as before it) does not beat the pick;
    None when that cannot be told without the usual pass."""
    if now > pick.at + slot:
        return None  # the reply came late
    reply = life.reply
    if reply is None or life.request.poll_seq != pick.poll_seq:
        return None
    frag, peer = reply.fragment, life.peer
    if frag is not None and frag.count != 1:
        return None  # a fragment of a larger update: its want and ack change
    if pacing and (frag is None or peer.pace.paced):
        return None  # its pace decides when it is due again
    if site_links.shared(life.request.follower) \
            and peer.reliability.after(True) != peer.reliability.value:
        return None  # the answer changes its site's p: the others' indices move too
    fresh_from = now if frag is None else peer.clock.to_leader(frag.generated_at)
    age = max(pick.at - max(peer.policy_tau, fresh_from), 0.0) / slot
    i = table.index(life.request.follower)
    value = pick.index(table.w[i], peer.reliability.after(True), age)
    if value > pick.value or (value == pick.value and i < pick.choice):
        return None
    return pick.choice
