"""The election on real liveliness tokens: a flapping token of the active leader hands
nothing over; one that stays away does, after the grace. Real sessions on loopback."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zenoh

from wiswarm_zenoh.transport import SwarmKeys
from wiswarm_zenoh.transport.election import ASK_TIMEOUT, Election

from .helpers import WAIT, Sessions, eventually

SWARM = "elect"
GRACE = 0.5  # seconds: long enough that a token put back at once is surely within it


def _token_known(session: zenoh.Session, key: str) -> None:
    """Until ``session`` can see the token ``key`` (declarations travel via the router)."""
    eventually(f"{key} known", lambda: any(
        r.ok is not None for r in session.liveliness().get(key, timeout=1.0)))


def test_a_flapping_token_keeps_its_leader_and_a_lasting_loss_hands_over(
    sessions: Sessions, router: zenoh.Session, port: int, caplog: pytest.LogCaptureFixture
) -> None:
    keys = SwarmKeys(SWARM)
    other = sessions.node(port).liveliness()
    older = other.declare_token(keys.leader("older", 1))
    changes = threading.Semaphore(0)
    standby = sessions.node(port)
    _token_known(standby, keys.leader("older", 1))
    with caplog.at_level(logging.WARNING, "wiswarm_zenoh"):
        election = Election(standby, keys, "standby", 2, changes.release, grace=GRACE)
        try:
            assert election.active == (1, "older") and not election.leading
            for flap in (1, 2):  # gone and back at once, twice
                older.undeclare()
                older = other.declare_token(keys.leader("older", 1))
                eventually("the flap is seen", lambda n=flap: election.flaps == n)
                assert election.active == (1, "older")
            assert not changes.acquire(timeout=0)  # nothing was handed over
            assert "went and came back" in caplog.text
            gone_at = time.monotonic()
            older.undeclare()  # for good
            assert changes.acquire(timeout=WAIT), "the standby never took over"
            assert time.monotonic() - gone_at >= GRACE * 0.9  # not before the grace
            assert election.leading and election.flaps == 2
        finally:
            election.close()


def test_an_older_leader_appearing_is_obeyed_at_once(
    sessions: Sessions, router: zenoh.Session, port: int
) -> None:
    keys = SwarmKeys(SWARM)
    changes = threading.Semaphore(0)
    election = Election(sessions.node(port), keys, "young", 5, changes.release, grace=60.0)
    try:
        assert election.leading
        token = sessions.node(port).liveliness().declare_token(keys.leader("old", 1))
        assert changes.acquire(timeout=WAIT)  # no grace on the way down: well within 60 s
        assert election.active == (1, "old") and not election.leading
        token.undeclare()
    finally:
        election.close()


def test_a_leader_that_comes_while_a_standby_asks_again_stays_active(
    sessions: Sessions, router: zenoh.Session, port: int
) -> None:
    """A standby asks now and then which leaders are there (``recheck``). After a router
    restart everyone declares their token again: the answer can predate the active
    leader's, which the watch sees come meanwhile. That leader is there all the same:
    taking it for gone made the standby lead beside it for good."""
    keys = SwarmKeys(SWARM)
    changes = threading.Semaphore(0)
    election = Election(sessions.node(port), keys, "standby", 2, changes.release)
    other = sessions.node(port).liveliness()
    tokens: list[zenoh.LivelinessToken] = []

    def asked_before_the_leader_came_back() -> set[tuple[int, str]]:
        answer = {election.claim}  # a router's answer without it: this leader's only
        tokens.append(other.declare_token(keys.leader("older", 1)))
        eventually("the watch sees it come", lambda: election.active == (1, "older"))
        return answer

    try:
        assert election.leading
        election._there = asked_before_the_leader_came_back  # type: ignore[method-assign]
        election.recheck()
        assert election.active == (1, "older") and not election.leading
        election._there = lambda: {election.claim}  # type: ignore[method-assign]
        election.recheck()  # one answer lacking it: the first, the one before had it
        assert election.active == (1, "older")
    finally:
        election.close()


def test_a_claim_one_answer_lacks_stays_and_one_two_answers_lack_is_gone(
    sessions: Sessions, router: zenoh.Session, port: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A claim only answers gave (its token went before the watch could see it): one
    answer without it leaves it, as does one that timed out (None); two in a row drop
    it. A claim the watch saw come stays however many answers lack it."""
    keys = SwarmKeys(SWARM)
    changes = threading.Semaphore(0)
    older = sessions.node(port, "client").liveliness().declare_token(keys.leader("older", 3))
    standby = sessions.node(port, "client")
    _token_known(standby, keys.leader("older", 3))
    ghost = (1, "ghost")  # in the start's answers, never a token the watch sees
    asked = Election._there
    monkeypatch.setattr(Election, "_there", lambda self: (asked(self) or set()) | {ghost})
    election = Election(standby, keys, "standby", 5, changes.release)
    monkeypatch.undo()
    try:
        assert election.active == ghost
        # The premise: the watch saw older's token come (its history may still be on its
        # way on a busy host; then older was a claim only answers gave, and was dropped).
        eventually("the watch sees older", lambda: (3, "older") in election._watched)
        lacking = {election.claim}  # an answer with this leader's token only

        def answer(*answers: set[tuple[int, str]] | None) -> None:
            for each in answers:
                election._there = lambda a=each: None if a is None else set(a)  # type: ignore[method-assign]
                election.recheck()

        answer(lacking, None, lacking)  # no answer between: the next lacking one is first
        assert election.active == ghost
        answer({election.claim, ghost}, lacking)  # the answer between had it
        assert election.active == ghost
        answer(lacking)
        assert election.active == (3, "older") and changes.acquire(timeout=0)
        answer(lacking, lacking, lacking)  # the watch saw this one come, and not go
        assert election.active == (3, "older") and not election.leading
    finally:
        election.close()
        older.undeclare()


def test_answers_that_lack_a_token_the_watch_sees_change_nothing(
    sessions: Sessions, router: zenoh.Session, port: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """In peer mode an answer can lack a token that is there (eclipse-zenoh 1.10, on a
    busy host: a peer that reaches the token's holder directly and through the router).
    The watch does not miss it: a standby whose every answer lacks the older leader
    still starts standing by, and stays so."""
    keys = SwarmKeys(SWARM)
    changes = threading.Semaphore(0)
    older = sessions.node(port).liveliness().declare_token(keys.leader("older", 1))
    standby = sessions.node(port)
    _token_known(standby, keys.leader("older", 1))
    without_older = {(2, "standby")}  # what such an answer holds: this leader's token
    monkeypatch.setattr(Election, "_there", lambda self: set(without_older))
    election = Election(standby, keys, "standby", 2, changes.release)
    try:
        assert election.active == (1, "older") and not election.leading
        for _ in range(3):
            election.recheck()
        assert election.active == (1, "older") and not changes.acquire(timeout=0)
    finally:
        election.close()
        older.undeclare()


def test_a_standby_whose_router_answers_late_asks_again_and_stands_by(
    sessions: Sessions, port: int
) -> None:
    """The answer to "which leaders are there" holds this session's own token at once,
    router or not: one that timed out (a router frozen past the ask's timeout, as a busy
    host's can be) is only part of it, and a standby that took it for the whole would
    start polling beside the older leader. It asks again; and the answer that comes at
    the thaw, or the watch's history that comes with it, holds the older leader's token
    (an answer at the thaw alone lacked it)."""
    wiswarm = Path(sys.executable).with_name("wiswarm")
    router = subprocess.Popen(
        [str(wiswarm), "router", "-l", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert router.stdout is not None and "listening" in router.stdout.readline()
        keys = SwarmKeys(SWARM)
        # clients: every token and every ask goes through the router, none peer to peer
        older = sessions.node(port, "client").liveliness().declare_token(
            keys.leader("older", 1))
        standby = sessions.node(port, "client")
        _token_known(standby, keys.leader("older", 1))
        os.kill(router.pid, signal.SIGSTOP)
        thaw = threading.Timer(ASK_TIMEOUT + 0.5, os.kill, (router.pid, signal.SIGCONT))
        thaw.start()
        started = time.monotonic()
        election = Election(standby, keys, "standby", 2, lambda: None)
        try:
            assert time.monotonic() - started >= ASK_TIMEOUT  # the first ask timed out
            assert election.active == (1, "older") and not election.leading
        finally:
            thaw.join()
            election.close()
            older.undeclare()
    finally:
        os.kill(router.pid, signal.SIGCONT)
        router.terminate()
        router.wait(30)
