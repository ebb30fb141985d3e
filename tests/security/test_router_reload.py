"""A router takes its rewritten files by itself, in its turn, and never a broken one."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

import pytest

from wiswarm_zenoh.programs.router_reload import TURN, FileWatch, ReloadingRouter, Turn
from wiswarm_zenoh.security.deploy import add_follower
from wiswarm_zenoh.security.revoke import revoke
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.usage import UsageError

from .helpers import KEYS, Sessions, answer, replies, until


@pytest.mark.parametrize("routers", [2, 3])
def test_the_routers_of_a_place_take_turns_half_a_turn_apart(routers: int) -> None:
    turns = [Turn(k, routers) for k in range(routers)]
    clock = [k * TURN / 20 for k in range(40 * routers)]  # two cycles, in 20ths of a turn
    due = [[t.due(c) for t in turns] for c in clock]
    assert all(sum(row) <= 1 for row in due)  # never two at once
    assert all(any(row[k] for row in due) for k in range(routers))  # each has its turn
    for k, turn in enumerate(turns):  # and half a turn without anyone between two turns
        assert turn.due(k * TURN) and not turn.due(k * TURN + TURN / 2)
    assert Turn().due(0.7)  # a place's only router: any time


def test_a_change_is_taken_once_the_files_stopped_changing(tmp_path: Path) -> None:
    files = [tmp_path / "router.json5", tmp_path / "users.txt"]
    for path in files:
        path.write_text("a")
    watch = FileWatch([str(p) for p in files])
    assert watch.settled_change() == []
    files[0].write_text("b")
    assert watch.settled_change() == []  # changed since the last check: still moving
    files[1].write_text("b")
    assert watch.settled_change() == []
    assert watch.settled_change() == [str(p) for p in files]
    watch.take()
    assert watch.settled_change() == []


@pytest.fixture
def router(swarm: Path) -> Iterator[ReloadingRouter]:
    """The swarm's router as ``wiswarm router -c`` runs it, checked by hand."""
    router = ReloadingRouter(SessionSpec(config_file=str(swarm / "router.json5")))
    yield router
    router.close()


def _checked(router: ReloadingRouter, caplog: pytest.LogCaptureFixture) -> list[str]:
    """Two checks (a change is taken once it stayed so for one); what they logged."""
    caplog.clear()
    with caplog.at_level(logging.INFO, "wiswarm_zenoh.programs.router_reload"):
        router.check()
        router.check()
    return [record.levelname for record in caplog.records]


def test_a_router_takes_a_new_follower_and_runs_on_through_a_broken_config(
        swarm: Path, sessions: Sessions, router: ReloadingRouter,
        caplog: pytest.LogCaptureFixture) -> None:
    leader = sessions.open("leader")
    add_follower(swarm, "f3")
    first = router.session.zid()
    router.check()  # the files changed since the last look: not yet
    assert router.session.zid() == first
    assert _checked(router, caplog) == ["INFO"]
    assert router.session.zid() != first and "router.json5" in caplog.text
    queryable = answer(sessions.open("f3"), KEYS.update("f3"), b"f3")
    until("f3 answers a poll", lambda: replies(leader, KEYS.update("f3"), 1.0) == [b"f3"])
    queryable.undeclare()
    second = router.session.zid()
    (swarm / "router.json5").write_text("{ not json")
    assert _checked(router, caplog) == ["ERROR"] and "runs on as it was" in caplog.text
    assert router.session.zid() == second
    sessions.open("f2")  # still a router


def test_a_revoked_nodes_session_ends_with_the_routers_old_one(
        swarm: Path, sessions: Sessions, router: ReloadingRouter,
        caplog: pytest.LogCaptureFixture) -> None:
    f1 = sessions.open("f1")
    revoke(swarm, "f1")
    assert _checked(router, caplog) == ["INFO"] and "users.txt" in caplog.text
    with pytest.raises(UsageError, match="no router answered"):
        sessions.open("f1")
    assert not list(f1.info.routers_zid())
