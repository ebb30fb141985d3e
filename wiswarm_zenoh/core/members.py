"""Which members are one robot: a robot serving several streams from one process has a
member per stream, ``<robot>~<stream>`` (one session, one link: they join and leave
together), and a robot with one stream is its own member."""

from __future__ import annotations

STREAM_SEPARATOR = "~"


def robot_of(member: str) -> str:
    """The robot a member is a stream of (``uav1~camera`` → ``uav1``; a site's
    ``s1.uav1~camera`` → ``s1.uav1``); a member with one stream is its robot."""
    return member.split(STREAM_SEPARATOR, 1)[0]
