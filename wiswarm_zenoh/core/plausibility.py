"""Whether a reply can be the polled follower's own: its stamps must be ones that
follower's clock gives (see ``clock.ClockOffsetEstimator.judge``)."""

from __future__ import annotations

from wiswarm_zenoh.core.clock import STAMP_SLACK, ClockOffsetEstimator
from wiswarm_zenoh.core.wire import Reply


def implausible(clock: ClockOffsetEstimator, sent_at: float, reply: Reply, now: float,
                refused_before: bool) -> tuple[str, bool] | None:
    """Why ``reply`` to a poll sent at ``sent_at`` cannot be the polled follower's
    answer, and whether it was for its clock stamps (no clock of that follower gives
    them: the poll then counts once against the clock's estimate), or None.
    ``refused_before``: a reply to this poll was refused for its stamps already (a
    streak of refused polls, not of replies to one poll, re-anchors the estimate).
    Nothing changes here."""
    reason = clock.judge(sent_at, reply.received_at, reply.sent_at, now,
                         reanchor=not refused_before)
    if reason is not None:
        return reason, True
    frag = reply.fragment
    if frag is not None and frag.generated_at > reply.sent_at + STAMP_SLACK:
        return (f"update generated {frag.generated_at - reply.sent_at:.3f} s after "
                "the reply carrying it was sent"), False
    return None
