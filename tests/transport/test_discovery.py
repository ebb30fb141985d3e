"""Discovery that recovers from a missed answer, with real sessions: a router whose
access control refuses every liveliness watch (a ``declare_liveliness_subscriber``
denied) but answers liveliness gets stands for the watch that missed a token in Zenoh's
peer mode (issue 40). Before ``discovery``, such a leader never polled a follower."""

from __future__ import annotations

import json
import logging
import time

import pytest
import zenoh

from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SessionSpec
from wiswarm_zenoh.transport.discovery import Discovery

from .helpers import Recorder, Sessions, eventually

SWARM = "blind"
JOIN_WITHIN = 2.0  # seconds: the bound on a join


def blind_router(sessions: Sessions, port: int) -> zenoh.Session:
    """A loopback router that refuses every liveliness subscriber on ``wiswarm/**``."""
    config = SessionSpec.loopback("router", port).config()
    config.insert_json5("access_control", json.dumps({
        "enabled": True, "default_permission": "allow",
        "rules": [{"id": "no-watch", "messages": ["declare_liveliness_subscriber"],
                   "flows": ["ingress", "egress"], "permission": "deny",
                   "key_exprs": ["wiswarm/**"]}],
        "subjects": [{"id": "loopback", "interfaces": ["lo"]}],
        "policies": [{"rules": ["no-watch"], "subjects": ["loopback"]}]}))
    session = zenoh.open(config)
    sessions.opened.append(session)
    return session


def found_lines(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if "found by asking again" in r.getMessage()]


def test_the_watch_is_refused_here_but_an_answer_holds_the_token(
        sessions: Sessions, port: int) -> None:
    """The premise: on this router a watch never hears of a token an answer holds."""
    blind_router(sessions, port)
    holder = sessions.node(port, "client")
    _token = holder.liveliness().declare_token("wiswarm/blind/members/d1")
    asker = sessions.node(port, "client")
    seen: list[zenoh.Sample] = []
    _watch = asker.liveliness().declare_subscriber("wiswarm/blind/members/*", seen.append,
                                                   history=True)

    def answer() -> list[str]:
        return sorted(str(r.ok.key_expr) for r in asker.liveliness().get(
            "wiswarm/blind/members/*", timeout=5) if r.ok)

    eventually("an answer holds d1", lambda: answer() == ["wiswarm/blind/members/d1"])
    _other = holder.liveliness().declare_token("wiswarm/blind/members/d2")  # after the watch
    eventually("an answer holds d2", lambda: len(answer()) == 2)
    assert seen == []


@pytest.mark.parametrize("mode", ["client", "peer"])
def test_a_leader_whose_watch_missed_finds_followers_by_asking_within_2_s(
        sessions: Sessions, port: int, recorder: Recorder, mode: str,
        caplog: pytest.LogCaptureFixture) -> None:
    """The leader in either mode; the followers are clients, so that what the leader
    hears of them passes the router (a peer follower would be gossiped to the leader, a
    link the router cannot refuse)."""
    caplog.set_level(logging.INFO, logger="wiswarm_zenoh.transport.discovery")
    blind_router(sessions, port)
    before = FollowerNode(sessions.node(port, "client"), SWARM, "before")
    started = time.monotonic()
    with LeaderNode(sessions.node(port, mode), SWARM, **recorder.callbacks()) as leader:
        recorder.wait("the follower up before", lambda r: r.joins == ["before"])
        assert time.monotonic() - started < JOIN_WITHIN
        before.offer(b"polled")
        recorder.wait("a delivery", lambda r: r.count("before") == 1)
        started = time.monotonic()
        after_session = sessions.node(port, "client")
        FollowerNode(after_session, SWARM, "after")
        recorder.wait("the follower up after", lambda r: r.joins == ["before", "after"])
        assert time.monotonic() - started < JOIN_WITHIN
        assert sorted(leader.followers) == ["after", "before"]
        assert len(found_lines(caplog)) == 2  # once each, saying why
        after_session.close()  # gone: answers alone gave it, answers take it away
        recorder.wait("a leave", lambda r: r.leaves == ["after"])
        assert leader.followers == ["before"]


def test_a_token_the_watch_saw_is_neither_found_again_nor_dropped_by_answers(
        sessions: Sessions, router: zenoh.Session, port: int) -> None:
    """On a router that lets the watch see: answers confirm it and add nothing."""
    changes: list[tuple[str, bool]] = []
    holder = sessions.node(port, "client")
    token = holder.liveliness().declare_token("wiswarm/seen/members/d1")
    discovery = Discovery(sessions.node(port, "client"), "wiswarm/seen/members/*",
                          lambda key, alive: changes.append((key, alive)), "test token")
    try:
        eventually("25 answers", lambda: discovery.reasks >= 25)
        assert changes == [("wiswarm/seen/members/d1", True)]
        assert discovery.found_by_answer == 0
        token.undeclare()
        eventually("the watch saw it go", lambda: len(changes) == 2)
        assert changes[1] == ("wiswarm/seen/members/d1", False)
    finally:
        discovery.close()
