"""What other tools see (stats JSON, fresh updates), and the ways nodes can be wired up:
through a router, peer to peer, and across a router restart."""

from __future__ import annotations

import json
import os

import zenoh

from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SessionSpec
from wiswarm_zenoh.transport.stats_rounds import STATS_PERIOD
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

from .helpers import Recorder, Samples, Sessions, wait_until_known

SWARM = "s"
FOLLOWER_FIELDS = {"follower", "aoi_s", "mean_aoi_s", "p95_aoi_s", "p_hat", "weight", "polls",
                   "deliveries", "timeouts", "errors"}
LEADER_FIELDS = {"followers", "polls_per_s", "mean_aoi_s", "policy", "uptime_s"}


def test_a_plain_subscriber_reads_the_stats_json_and_the_fresh_updates(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    follower = FollowerNode(sessions.node(port), SWARM, "uav1")
    watch = Samples(sessions.node(port), f"wiswarm/{SWARM}/**")
    update = os.urandom(3000)
    leader_session = sessions.node(port)
    fresh_key = f"wiswarm/{SWARM}/uav1/fresh"
    stats_key = f"wiswarm/{SWARM}/uav1/stats"
    leader_key = f"wiswarm/{SWARM}/leader/stats"
    with LeaderNode(leader_session, SWARM, **recorder.callbacks()):
        recorder.wait("join", lambda r: bool(r.joins))
        wait_until_known(leader_session, fresh_key)
        follower.offer(update)
        watch.wait("the fresh update", lambda w: any(
            str(s.key_expr) == fresh_key for s in w.samples))
        watch.wait("stats counting it", lambda w: any(
            int(r["deliveries"]) == 1 for r in w.stats(stats_key)))
        # The first leader stats go out before anyone joined: wait for one that lists uav1
        # (put right after the follower's stats, so it may still be on its way).
        watch.wait("the leader's stats listing uav1", lambda w: any(
            r["followers"] == ["uav1"] for r in w.stats(leader_key)))
    fresh = next(s for s in watch.samples if str(s.key_expr) == fresh_key)
    assert fresh.payload.to_bytes() == update
    assert fresh.attachment is not None
    meta = json.loads(fresh.attachment.to_bytes())
    assert meta["follower"] == "uav1" and meta["update_seq"] == 1
    assert meta["delivered_at"] >= meta["generated_at"]
    stats = next(s for s in watch.samples if str(s.key_expr) == stats_key)
    assert str(stats.encoding) == "application/json"
    record = watch.stats(stats_key)[-1]
    assert record.keys() >= FOLLOWER_FIELDS
    assert record["follower"] == "uav1" and 0.0 < record["p_hat"] <= 1.0
    assert record["polls"] >= record["deliveries"] == 1
    leader = next(r for r in watch.stats(leader_key) if r["followers"] == ["uav1"])
    assert leader.keys() >= LEADER_FIELDS
    assert leader["policy"] == "whittle"


def _delivers(leader_session: zenoh.Session, follower: FollowerNode) -> None:
    recorder = Recorder()
    with LeaderNode(leader_session, SWARM, **recorder.callbacks()):
        recorder.wait("join", lambda r: bool(r.joins))
        follower.offer(b"frame")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 1)


def test_stats_come_at_the_documented_rate_once_each(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    """The README's 2.5 Hz (the design asks at least 2), measured as a plain subscriber
    sees it: peers through a router (each one reached both directly and through it),
    over about 3 s."""
    followers = [FollowerNode(sessions.node(port), SWARM, f"uav{i}") for i in (1, 2)]
    leader_key, stats_key = f"wiswarm/{SWARM}/leader/stats", f"wiswarm/{SWARM}/uav1/stats"
    with LeaderNode(sessions.node(port), SWARM, **recorder.callbacks()):
        recorder.wait("joins", lambda r: len(r.joins) == 2)
        watch = Samples(sessions.node(port), f"wiswarm/{SWARM}/*/stats")
        watch.wait("8 leader stats", lambda w: len(w.stats(leader_key)) >= 8)
        for key in (leader_key, stats_key):
            rate, copies = watch.rate(key)
            assert 2.0 <= rate <= 1.1 / STATS_PERIOD and copies == 0, (key, rate, copies)
    for follower in followers:
        follower.close()


def test_clients_through_a_router_in_the_middle(
    sessions: Sessions, router: zenoh.Session, port: int
) -> None:
    follower = FollowerNode(sessions.node(port, "client"), SWARM, "uav1")
    _delivers(sessions.node(port, "client"), follower)


def test_peer_to_peer_without_a_router(sessions: Sessions, port: int) -> None:
    follower = FollowerNode(sessions.open(SessionSpec.loopback("peer", listen_port=port)),
                            SWARM, "uav1")
    _delivers(sessions.open(SessionSpec.loopback("peer", connect_ports=[port])), follower)


def test_nodes_survive_a_router_restart(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    follower = FollowerNode(sessions.node(port, "client"), SWARM, "uav1")
    with LeaderNode(sessions.node(port, "client"), SWARM, **recorder.callbacks()):
        follower.offer(b"before")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 1)
        router.close()
        recorder.wait("router gone: the follower looks gone", lambda r: r.leaves == ["uav1"])
        sessions.router(port)  # the same endpoint again
        recorder.wait("reconnected", lambda r: r.joins == ["uav1", "uav1"])
        follower.offer(b"after")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 2)
    assert recorder.deliveries[-1].payload == b"after"


def test_a_router_failover_is_no_leave(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    """Two routers, every node a client given both: when the one carrying them dies, the
    other takes them within milliseconds; the follower's token goes and comes back, and
    the leader takes that for what it is, not for a leave and a join."""
    second = free_tcp_port()
    sessions.open(SessionSpec(mode="router", listen=(f"tcp/127.0.0.1:{second}",),
                              connect=(f"tcp/127.0.0.1:{port}",), multicast_scouting=False))
    both = SessionSpec.loopback("client", connect_ports=[port, second])
    follower = FollowerNode(sessions.open(both), SWARM, "uav1")
    with LeaderNode(sessions.open(both), SWARM, **recorder.callbacks()):
        follower.offer(b"before")
        recorder.wait("delivery", lambda r: len(r.deliveries) == 1)
        router.close()  # the first endpoint's: both nodes are its clients
        follower.offer(b"after")
        recorder.wait("delivery over the other router", lambda r: len(r.deliveries) == 2)
        assert recorder.joins == ["uav1"] and recorder.leaves == []
