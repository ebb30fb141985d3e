"""A follower serving what the robot already publishes on a Zenoh key (``--source``):
the bytes reach the leader's ``fresh`` key unchanged, stamped with the sample's Zenoh
timestamp; a sample that overtook a newer one never replaces it; a key nothing is
published on yet is said once, and the follower waits."""

from __future__ import annotations

import datetime
import logging
import time

import pytest
import zenoh

from tests.transport.helpers import Recorder, Sessions, eventually, wait_until_known
from wiswarm_zenoh import Follower, ZenohSource
from wiswarm_zenoh.cli import main as cli_main
from wiswarm_zenoh.cli import nodes
from wiswarm_zenoh.transport import LeaderNode, SwarmKeys, source_feed

SWARM = "keys"
SOURCE = "robot/lidar/scan"


def stamp(session: zenoh.Session, seconds: float) -> zenoh.Timestamp:
    """A Zenoh timestamp of ``seconds`` since the epoch, from ``session``'s clock id."""
    return zenoh.Timestamp(datetime.datetime.fromtimestamp(seconds, datetime.UTC),
                           session.new_timestamp().get_id())


def test_plain_puts_reach_fresh_unchanged_with_their_own_time(
        sessions: Sessions, port: int, recorder: Recorder,
        caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO)
    sessions.router(port)
    robot = sessions.node(port)
    follower = Follower(robot, SWARM, "r1", source=ZenohSource(SOURCE))
    leader_session = sessions.node(port)
    leader = LeaderNode(leader_session, SWARM, **recorder.callbacks())
    ground = sessions.node(port)
    fresh: list[bytes] = []
    subscriber = ground.declare_subscriber(SwarmKeys(SWARM).fresh("r1"),
                                           lambda s: fresh.append(s.payload.to_bytes()))
    # ``fresh`` is put only while someone subscribes, and the scan below is put once:
    # the ground's subscription must have reached the leader (slow on a busy machine).
    wait_until_known(leader_session, SwarmKeys(SWARM).fresh("r1"))
    try:
        assert any(f"waiting for the first sample of key {SOURCE}" in r.getMessage()
                   for r in caplog.records)
        eventually("the leader sees r1", lambda: "r1" in recorder.joins)
        assert recorder.count("r1") == 0  # nothing published: nothing delivered
        made_at = time.time() - 2.0
        scan = bytes(range(256)) * 40  # 10 kB: fragmented by nothing, copied by nothing
        robot.put(SOURCE, scan, timestamp=stamp(robot, made_at))
        recorder.wait("the scan delivered", lambda r: r.count("r1") >= 1)
        delivered = next(d for d in recorder.deliveries if d.follower == "r1")
        assert delivered.payload == scan
        assert abs(delivered.generated_at - made_at) < 0.5  # its own time, not its arrival
        eventually("the scan on fresh", lambda: scan in fresh)

        robot.put(SOURCE, b"older", timestamp=stamp(robot, made_at - 1.0))
        feed = follower.source
        assert feed is not None
        eventually("the older sample skipped", lambda: feed.older == 1)
        assert feed.samples == 1
        robot.put(SOURCE, b"newer")  # no timestamp given: the router's, or its arrival
        recorder.wait("the newer one delivered",
                      lambda r: any(d.payload == b"newer" for d in r.deliveries))
        assert all(d.payload != b"older" for d in recorder.deliveries)
    finally:
        subscriber.undeclare()
        leader.close()
        follower.close()


def test_a_key_expression_is_checked_when_given() -> None:
    with pytest.raises(ValueError, match="not a key expression: 'a//b' \\(Invalid Key"):
        ZenohSource("a//b")


@pytest.mark.parametrize(("argv", "message"), [
    (["--source", "a//b"], "--source: not a key expression: 'a//b' (Invalid Key Expr"),
    (["--ros2-topic", "camera/raw"], "a ROS topic is /token[/token...]"),
    (["--ros2-waypoints", "/path/"], "a ROS topic is /token[/token...]"),
    (["--source", "a/b", "--ros2-topic", "/a/b"], "a/b and /a/b are both member 'r1~a_b'"),
    (["--ros-domain", "3"], "--ros-domain is for --ros2-topic or --ros2-waypoints"),
    (["--ros2-topic", "/t", "--ros-domain", "300"], "--ros-domain"),
    (["--source", "a/b", "--rate", "5"], "--rate paces synthetic frames"),
    (["--system", "push", "--source", "a/b"], "--source is for --system wiswarm, not push"),
])
def test_bad_source_flags_are_one_line_and_exit_2(
        capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    assert cli_main.main(["follower", "--id", "r1", *argv],
                         registrars=(nodes.register,)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("wiswarm follower: error: ")
    assert message in err


def test_a_source_silent_for_a_while_is_named_in_one_warning(
        sessions: Sessions, port: int, caplog: pytest.LogCaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A mistyped key or topic: nothing ever comes. At the default level (WARNING) the
    user still sees which source is silent, once."""
    monkeypatch.setattr(source_feed, "SILENT_AFTER", 0.2)
    caplog.set_level(logging.WARNING)
    sessions.router(port)
    follower = Follower(sessions.node(port), SWARM, "r1", source=ZenohSource("robot/typo"))
    try:
        eventually("the warning", lambda: any("no sample of key robot/typo in 0 s"
                                              in r.getMessage() for r in caplog.records))
    finally:
        follower.close()
    assert len([r for r in caplog.records if "no sample of" in r.getMessage()]) == 1


def test_a_source_that_speaks_in_time_is_not_warned_about(
        sessions: Sessions, port: int, caplog: pytest.LogCaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(source_feed, "SILENT_AFTER", 1.0)
    caplog.set_level(logging.INFO)
    sessions.router(port)
    robot = sessions.node(port)
    follower = Follower(robot, SWARM, "r1", source=ZenohSource(SOURCE))
    try:
        robot.put(SOURCE, b"at once")
        eventually("served", lambda: any("serving key" in r.getMessage()
                                         for r in caplog.records))
        served = next(r for r in caplog.records if "serving key" in r.getMessage())
        eventually("a second after", lambda: time.time() > served.created + 1.5)
    finally:
        follower.close()
    assert not any("no sample of" in r.getMessage() for r in caplog.records)
