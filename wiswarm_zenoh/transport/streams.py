"""A robot's streams: each source a follower process serves (``wiswarm follower
--ros2-topic``/``--source``, given several times) is a member of its own, polled and
aged on its own, on the process's one session (the robot's link).

Names a user can predict: a robot with one stream, unnamed, is the member ``<id>`` (as
ever); otherwise each stream is ``<id>~<name>``, its name given (``NAME=TOPIC``) or the
topic or key expression itself with every run of characters other than letters, digits
and ``_`` made one ``_`` (``/drone1/camera/image_raw`` → ``drone1_camera_image_raw``)."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from wiswarm_zenoh.core.messages import MAX_ID_BYTES
from wiswarm_zenoh.transport.keys import stream_member
from wiswarm_zenoh.transport.source_feed import Source

_NAMED = re.compile(r"([A-Za-z0-9_]+)=(.+)", re.DOTALL)
_OTHER = re.compile(r"[^A-Za-z0-9_]+")


@dataclass(frozen=True)
class Stream:
    """``source``, served by the member ``member``; ``what`` names it in logs."""

    member: str
    source: Source
    what: str


def split_name(text: str) -> tuple[str | None, str]:
    """``NAME=VALUE`` as (NAME, VALUE); anything else as (None, text)."""
    named = _NAMED.fullmatch(text)
    return (named.group(1), named.group(2)) if named else (None, text)


def stream_name(value: str) -> str:
    """The name a stream of ``value`` (a topic or key expression) gets if not given one."""
    name = _OTHER.sub("_", value).strip("_")
    if not name:
        raise ValueError(f"{value!r} has no letter or digit to name its stream: give "
                         "it a name, NAME=...")
    return name


def robot_streams(robot: str, given: Sequence[tuple[str | None, Source, str]]) -> \
        tuple[Stream, ...]:
    """The members of ``robot``'s streams, from (name or None, source, what the user
    wrote) each; ValueError saying why for names that clash or are too long."""
    if len(given) == 1 and given[0][0] is None:
        _, source, what = given[0]
        return (Stream(robot, source, what),)
    streams: list[Stream] = []
    for name, source, what in given:
        member = stream_member(robot, name or stream_name(what))
        size = len(member.encode("utf-8"))
        if size > MAX_ID_BYTES:
            raise ValueError(f"the stream of {what} would be member {member!r}, {size} "
                             f"bytes long (at most {MAX_ID_BYTES}): name it, NAME={what}")
        clash = next((s for s in streams if member == s.member or what == s.what), None)
        if clash is not None:
            if what == clash.what:
                raise ValueError(f"{what} given twice: a robot serves a stream once")
            raise ValueError(f"{clash.what} and {what} are both member {member!r}: name "
                             f"one, NAME={what}")
        streams.append(Stream(member, source, what))
    return tuple(streams)
