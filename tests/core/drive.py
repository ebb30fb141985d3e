"""Drives a Leader and Followers by hand, with explicit times, for the leader tests."""

from __future__ import annotations

from collections.abc import Mapping

from wiswarm_zenoh.core import Event, Follower, Leader, PollRequest, drain
from wiswarm_zenoh.core.wire import Poll, Reply, decode_poll, decode_reply


def poll(leader: Leader, now: float) -> PollRequest:
    """A poll that must exist (a follower is known and nothing is in flight)."""
    request = leader.next_poll(now)
    assert request is not None
    return request


def poll_when_due(leader: Leader, now: float) -> PollRequest:
    """The next poll, at ``now`` or, when no source is due yet (``sources``), at the
    leader's timer: its ``sent_at`` says which."""
    request = leader.next_poll(now)
    if request is None:
        wake = leader.get_timer()
        assert wake is not None and wake > now
        request = leader.next_poll(wake)
    assert request is not None
    return request


def exchange(
    leader: Leader,
    followers: Mapping[str, Follower],
    now: float,
    latency: float = 0.001,
    clock_offset: float = 0.0,
) -> tuple[PollRequest, Reply, list[Event]]:
    """One poll answered over a lossless link: leader at ``now``, follower ``latency`` later.

    ``clock_offset`` is added to every time the follower sees (its clock is off by it).
    """
    request = poll(leader, now)
    at_follower = now + latency + clock_offset
    raw = followers[request.follower].on_poll(request.payload, at_follower, at_follower)
    events = on_reply(leader, request.follower, raw, now + 2 * latency)
    return request, decode_reply(raw), events


def poll_message(request: PollRequest) -> Poll:
    return decode_poll(request.payload)


def answer(
    leader: Leader,
    followers: Mapping[str, Follower],
    request: PollRequest,
    now: float,
    latency: float = 0.001,
) -> list[Event]:
    """The follower answers ``request`` (sent at ``now``) over a lossless link."""
    at = now + latency
    raw = followers[request.follower].on_poll(request.payload, at, at)
    return on_reply(leader, request.follower, raw, at + latency)


def on_reply(leader: Leader, follower: str, data: bytes, now: float) -> list[Event]:
    """A reply fed to the leader, and every event it then has."""
    leader.receive_reply(follower, data, now)
    return drain(leader)


def on_timer(leader: Leader, now: float) -> list[Event]:
    """The leader's timer fired at ``now``, and every event it then has."""
    leader.handle_timer(now)
    return drain(leader)
