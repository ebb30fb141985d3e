"""What a member's name says: which robot it is a stream of (a robot serving several
streams from one process has a member per stream, ``<robot>~<stream>``: one session,
one link, they join and leave together; a robot with one stream is its own member), and
which site it is of (a cloud's members are its sites' followers, ``<site>.<follower>``:
a site's share its link and hear only their site's control)."""

from __future__ import annotations

STREAM_SEPARATOR = "~"
SITE_SEPARATOR = "."


def robot_of(member: str) -> str:
    """The robot a member is a stream of (``uav1~camera`` → ``uav1``; a site's
    ``s1.uav1~camera`` → ``s1.uav1``); a member with one stream is its robot."""
    return member.split(STREAM_SEPARATOR, 1)[0]


def site_of(member: str) -> str | None:
    """The site of a member named ``<site>.<follower>``; None for a member of no site."""
    site, dot, _ = member.partition(SITE_SEPARATOR)
    return site if dot else None
