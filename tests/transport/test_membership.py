"""Discovery by liveliness: join, leave, rejoin; followers that die or hang; leader restart."""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import threading
from typing import NoReturn

import pytest
import zenoh

from wiswarm_zenoh.core import FollowerConfig, LeaderConfig
from wiswarm_zenoh.programs.frames import SyntheticFrames
from wiswarm_zenoh.programs.runners import FollowerOptions, run_child, run_follower
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SessionSpec

from .helpers import WAIT, Recorder, Samples, Sessions, eventually

SWARM = "m"


def test_join_leave_and_rejoin_with_a_reset_sequence(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    with LeaderNode(sessions.node(port), SWARM, **recorder.callbacks()) as leader:
        first = sessions.node(port)
        node = FollowerNode(first, SWARM, "uav1")
        recorder.wait("join", lambda r: r.joins == ["uav1"])
        for n in (1, 2):
            node.offer(b"before %d" % n)
            recorder.wait("delivery", lambda r, n=n: len(r.deliveries) == n)
        first.close()  # the process "restarts": its token goes with its session
        recorder.wait("leave", lambda r: r.leaves == ["uav1"])
        assert leader.followers == []
        node = FollowerNode(sessions.node(port), SWARM, "uav1")
        recorder.wait("rejoin", lambda r: r.joins == ["uav1", "uav1"])
        node.offer(b"after restart")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 3)
        assert leader.followers == ["uav1"]
    assert [d.update_seq for d in recorder.deliveries] == [1, 2, 1]
    assert recorder.deliveries[-1].payload == b"after restart"


def test_a_restarted_leader_finds_the_followers_and_their_queued_update(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    node = FollowerNode(sessions.node(port), SWARM, "uav1")
    with LeaderNode(sessions.node(port), SWARM, on_delivery=recorder.on_delivery):
        node.offer(b"one")
        recorder.wait("first leader", lambda r: len(r.deliveries) == 1)
    node.offer(b"two")  # nobody polls: it waits in the queue
    again = Recorder()
    with LeaderNode(sessions.node(port), SWARM, **again.callbacks()):
        again.wait("second leader", lambda r: len(r.deliveries) == 1)
    assert again.joins == ["uav1"]
    assert (again.deliveries[0].payload, again.deliveries[0].update_seq) == (b"two", 2)


def test_a_follower_killed_mid_update_is_timed_out_then_forgotten(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    steady = FollowerNode(sessions.node(port), SWARM, "steady")
    frames = SyntheticFrames(steady.offer, size=2000, rate=100.0)
    ctx = multiprocessing.get_context("spawn")
    ready = ctx.Event()
    options = FollowerOptions(SWARM, "victim", FollowerConfig(fragment_size=4096))
    spec = SessionSpec.loopback("peer", connect_ports=[port])
    victim = ctx.Process(target=run_child, args=(run_follower, (spec, options), ready))
    victim.start()
    try:
        assert ready.wait(WAIT)
        with LeaderNode(sessions.node(port), SWARM, **recorder.callbacks()) as leader:
            frames.start()
            # 50 kB in 4 kB fragments: 13 polls per frame, so it is nearly always mid-update.
            recorder.wait("victim delivers", lambda r: r.count("victim") >= 2)
            assert victim.pid is not None
            os.kill(victim.pid, signal.SIGKILL)
            recorder.wait("victim forgotten", lambda r: "victim" in r.leaves)
            after = recorder.count("steady")
            recorder.wait("steady still served", lambda r: r.count("steady") >= after + 10)
            assert leader.followers == ["steady"]
    finally:
        frames.stop()
        victim.kill()
        victim.join(WAIT)


def test_a_hung_follower_costs_one_timeout_per_poll_and_its_p_hat_falls(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    held: list[zenoh.Query] = []  # never answered nor dropped: Zenoh's timeout ends them
    hung = sessions.node(port)
    hung_queryable = hung.declare_queryable(f"wiswarm/{SWARM}/hung/update", held.append)
    hung_token = hung.liveliness().declare_token(f"wiswarm/{SWARM}/members/hung")
    steady = FollowerNode(sessions.node(port), SWARM, "steady")
    frames = SyntheticFrames(steady.offer, size=2000, rate=100.0)
    watch = Samples(sessions.node(port), f"wiswarm/{SWARM}/hung/stats")
    key = f"wiswarm/{SWARM}/hung/stats"
    config = LeaderConfig(timeout=0.05, window=10)
    with LeaderNode(sessions.node(port), SWARM, config, stats_period=0.1,
                    **recorder.callbacks()):
        frames.start()
        try:
            watch.wait("p_hat falls", lambda w: any(
                float(s["p_hat"]) < 0.5 and int(s["timeouts"]) >= 5 for s in w.stats(key)))
            # Its age keeps growing, so the policy comes back to it more and more often
            # (until its token goes, after Zenoh's lease); the others are still served.
            recorder.wait("steady served", lambda r: r.count("steady") >= 5)
        finally:
            frames.stop()
    last = watch.stats(key)[-1]
    assert int(last["deliveries"]) == 0
    assert int(last["polls"]) - 1 <= int(last["timeouts"]) <= int(last["polls"])
    for query in held:
        query.drop()
    hung_queryable.undeclare()
    hung_token.undeclare()


def test_a_follower_that_left_ages_in_its_stats_then_is_forgotten(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A vanished follower (a site cut off upstream) is not reported fresh: its stats go
    on with its age growing and ``present`` false; back, its age is not reset; gone for
    ``forget_after``, it is forgotten."""
    key = f"wiswarm/{SWARM}/uav1/stats"
    watch = Samples(sessions.node(port), key)
    with caplog.at_level(logging.INFO, "wiswarm_zenoh"), \
            LeaderNode(sessions.node(port), SWARM, stats_period=0.05, forget_after=1.0,
                       every_record=True, **recorder.callbacks()) as leader:
        first = sessions.node(port)
        node = FollowerNode(first, SWARM, "uav1")
        node.offer(b"frame")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 1)
        first.close()
        recorder.wait("leave", lambda r: r.leaves == ["uav1"])
        watch.wait("ageing stats of the absent follower", lambda s: sum(
            not r["present"] and r["aoi_s"] > 0.3 for r in s.stats(key)) >= 2)
        ages = [r["aoi_s"] for r in watch.stats(key) if not r["present"]]
        assert ages == sorted(ages)  # it only grows
        node = FollowerNode(sessions.node(port), SWARM, "uav1")
        recorder.wait("rejoin", lambda r: r.joins == ["uav1", "uav1"])
        watch.wait("present again", lambda s: s.stats(key)[-1]["present"])
        assert watch.stats(key)[-1]["deliveries"] == 1  # taken up where it was
        node.close()
        recorder.wait("second leave", lambda r: r.leaves == ["uav1", "uav1"])
        eventually("forgotten", lambda: "uav1 forgotten" in caplog.text)
        eventually("out of the stats", lambda: not leader.latest)


class _BridgeThatFails:
    """A ``BridgeOptions`` whose bridge cannot open (its ROS 2 side is missing, say)."""

    def open(self, session: zenoh.Session, swarm: str, control: object) -> NoReturn:
        raise KeyboardInterrupt  # as Ctrl-C or SIGTERM in the middle of the leader's start


def test_a_leader_stopped_while_it_starts_leaves_nothing_behind(
    sessions: Sessions, router: zenoh.Session, port: int
) -> None:
    """What it declared before the stop is undeclared at once, before the caller closes
    the session (which raised ``Already borrowed`` under a leader half made): no leader
    token stays to hold off the next one, no poll thread runs."""
    session = sessions.node(port)
    watcher = sessions.node(port)
    with pytest.raises(KeyboardInterrupt):
        LeaderNode(session, SWARM, bridge=_BridgeThatFails())
    assert not [t for t in threading.enumerate() if t.name.startswith(f"leader-{SWARM}/")]
    eventually("the leader token undeclared",
               lambda: not list(watcher.liveliness().get(f"wiswarm/{SWARM}/leaders/**")))
    session.close()
    with LeaderNode(sessions.node(port), SWARM) as leader:  # the next one leads
        eventually("the next leader active", lambda: leader.active)
