"""Weights given to the leader before members join (``wiswarm leader --weight
MEMBER=W``): a member takes its weight when it joins and again when it comes back; a
member that never joins is named once; bad flags are one line and exit 2."""

from __future__ import annotations

import logging
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import zenoh

from wiswarm_zenoh.transport import FollowerNode, LeaderNode, weight_settings
from wiswarm_zenoh.transport.keys import SwarmKeys

from .helpers import WAIT, Recorder, Samples, Sessions, eventually

SWARM = "presets"
KEYS = SwarmKeys(SWARM)
WISWARM = Path(sys.executable).with_name("wiswarm")


def _weight(leader: LeaderNode, follower: str) -> float | None:
    return next((s.weight for s in leader.latest if s.follower == follower), None)


def test_a_preset_is_taken_at_join_and_again_when_the_member_comes_back(
        sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder) -> None:
    tool = sessions.node(port)
    with LeaderNode(sessions.node(port), SWARM, every_record=True, weights={"uav2": 4.0},
                    **recorder.callbacks()) as leader:
        uav1 = FollowerNode(sessions.node(port), SWARM, "uav1")
        uav2 = FollowerNode(sessions.node(port), SWARM, "uav2")
        recorder.wait("both join", lambda r: sorted(r.joins) == ["uav1", "uav2"])
        eventually("uav2 weighs 4", lambda: (_weight(leader, "uav1"),
                                             _weight(leader, "uav2")) == (1.0, 4.0))
        tool.put(KEYS.weight("uav2"), "0.5")  # a live setting holds while it stays
        eventually("uav2 weighs 0.5", lambda: _weight(leader, "uav2") == 0.5)
        uav2.close()
        recorder.wait("uav2 leaves", lambda r: r.leaves == ["uav2"])
        uav2 = FollowerNode(sessions.node(port), SWARM, "uav2")
        recorder.wait("uav2 comes back", lambda r: r.joins.count("uav2") == 2)
        eventually("uav2 weighs 4 again", lambda: _weight(leader, "uav2") == 4.0)
        assert _weight(leader, "uav1") == 1.0
        uav1.close()
        uav2.close()


def test_a_preset_whose_member_never_joins_is_named_once(
        sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder,
        caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(weight_settings, "PRESET_GRACE", 2.0)
    caplog.set_level(logging.WARNING, logger=weight_settings.__name__)
    uav1 = FollowerNode(sessions.node(port), SWARM, "uav1")  # up first: found at once
    with LeaderNode(sessions.node(port), SWARM, weights={"uav1": 2.0, "uav9": 3.0},
                    **recorder.callbacks()) as leader:
        recorder.wait("uav1 joins", lambda r: r.joins == ["uav1"])

        def said() -> list[str]:
            return [r.getMessage() for r in caplog.records if "weight preset" in
                    r.getMessage()]

        eventually("the warning", lambda: len(said()) == 1)
        eventually("two seconds of stats rounds after it", lambda: leader.summary.uptime_s > 4)
        assert len(said()) == 1
        assert "weight preset for uav9, but no such member joined in 2 s (members: uav1)" \
            in said()[0]
    uav1.close()


def test_the_cli_leader_weighs_a_member_from_its_join(
        sessions: Sessions, router: zenoh.Session, port: int) -> None:
    watcher = sessions.node(port)
    stats = Samples(watcher, KEYS.all_stats)
    leader = subprocess.Popen(
        [str(WISWARM), "leader", "--swarm", SWARM, "--weight", "uav2=4", "--weight",
         "uav1=0.25", "-e", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    followers = [FollowerNode(sessions.node(port), SWARM, f"uav{i}") for i in (1, 2, 3)]
    try:
        def weights() -> dict[str, float]:
            return {record["follower"]: record["weight"] for key in
                    (KEYS.stats(f"uav{i}") for i in (1, 2, 3)) for record in stats.stats(key)}

        stats.wait("every member's stats", lambda _: len(weights()) == 3)
        assert weights() == {"uav1": 0.25, "uav2": 4.0, "uav3": 1.0}
    finally:
        leader.send_signal(signal.SIGTERM)
        err = leader.communicate(timeout=WAIT)[1]
        for follower in followers:
            follower.close()
    assert leader.returncode == 0, err
    assert "weight preset" not in err  # every member joined


@pytest.mark.parametrize(("flags", "said"), [
    (["--weight", "uav1=4", "--weight", "uav1=2"],
     "--weight uav1 given twice (4, 2): one weight per member"),
    (["--weight", "uav1=-1"], "argument --weight: 'uav1=-1': must be >= 0, got -1"),
    (["--weight", "uav1"], "argument --weight: expected MEMBER=W"),
    (["--system", "push", "--weight", "uav1=2"], "--weight is for --system wiswarm"),
])
def test_a_bad_weight_flag_is_one_line_and_exit_2(flags: list[str], said: str) -> None:
    done = subprocess.run([str(WISWARM), "leader", *flags], capture_output=True, text=True,
                          timeout=WAIT)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("wiswarm leader: error: ")
    assert said in done.stderr
    assert done.stdout == ""
