"""The API a robot team embeds (``wiswarm_zenoh``'s own names): a follower's bytes reach
a leader's handlers, its waypoints reach the follower, an observer sees the swarm typed.
Real sessions on loopback."""

from __future__ import annotations

import inspect
import json
import math
import threading
import time

import pytest
import zenoh

import wiswarm_zenoh
from wiswarm_zenoh import (
    Delivered,
    DeliveryRecord,
    FifoChannel,
    Follower,
    FollowerStats,
    Leader,
    LeaderConfig,
    LeaderSummary,
    Observer,
    RingChannel,
    Waypoint,
)
from wiswarm_zenoh.api import handlers, observer

from .helpers import WAIT, Sessions, wait_until_known

SWARM = "api"


ALIASES = {"Handler": handlers, "Observation": observer}  # documented by the string after them


def test_every_public_name_is_documented() -> None:
    for name in wiswarm_zenoh.__all__:
        if name in ALIASES:
            source = inspect.getsource(ALIASES[name])
            assert f'{name}: TypeAlias = ' in source
            after = source.split(f"{name}: TypeAlias = ")[1].split("\n")[1]
            assert after.startswith('"""'), name
        elif name != "__version__":
            assert getattr(wiswarm_zenoh, name).__doc__, name
    for cls in (Follower, Leader, Observer, FifoChannel, handlers.Channel, handlers.Receiver):
        for attr, member in vars(cls).items():
            if not attr.startswith("_") or attr in ("__iter__",):
                assert member.__doc__, f"{cls.__name__}.{attr}"


def test_offered_bytes_reach_a_fifo_channel_and_waypoints_reach_the_follower(
        sessions: Sessions, router: zenoh.Session, port: int) -> None:
    steered: list[list[Waypoint]] = []
    heard = threading.Event()

    def on_control(waypoints: list[Waypoint]) -> None:
        steered.append(waypoints)
        heard.set()

    joined = threading.Event()
    with Follower(sessions.node(port), SWARM, "uav1", on_control=on_control) as follower, \
            Leader(sessions.node(port), SWARM, FifoChannel(8),
                   on_join=lambda _: joined.set()) as leader:
        follower.offer(b"first")
        first = leader.recv(WAIT)
        assert isinstance(first, Delivered)
        assert (first.follower, first.payload) == ("uav1", b"first")
        follower.offer(b"second")
        assert next(iter(leader)).payload == b"second"
        assert joined.is_set() and leader.followers == ["uav1"] and leader.active
        when = time.time() + 1.0  # (t, x, y, z): t on the leader's clock
        leader.set_control("uav1", [(when, 2.0, 3.0, 0.5)])
        assert heard.wait(WAIT)
        [(t, x, y, z)] = steered[-1]  # t on this follower's clock: the same host's
        assert (x, y, z) == (2.0, 3.0, 0.5) and t == pytest.approx(when, abs=0.1)
        leader.observe_urgency("uav1", 2.0)
        assert follower.polls > 0 and follower.offered == 2
    while leader.try_recv() is not None:  # what came after the last read
        pass
    assert list(leader) == [] and leader.recv() is None  # closed: no waiting


def test_a_sampler_feeds_a_callback_and_a_ring_keeps_the_latest(
        sessions: Sessions, router: zenoh.Session, port: int) -> None:
    counter = iter(range(1_000_000))
    got: list[Delivered] = []
    enough = threading.Event()

    def on_delivery(delivery: Delivered) -> None:
        got.append(delivery)
        if len(got) >= 20:
            enough.set()

    with Follower(sessions.node(port), SWARM, "cam", sampler=lambda: b"%d" % next(counter)), \
            Leader(sessions.node(port), SWARM, on_delivery):
        assert enough.wait(WAIT)
    numbers = [int(d.payload) for d in got]
    assert numbers == sorted(numbers) and len(set(numbers)) == len(numbers)  # fresh each poll

    ring: RingChannel[int] = RingChannel(2)
    for n in range(5):
        ring.put(n)
    assert [ring.try_recv(), ring.try_recv(), ring.try_recv()] == [3, 4, None]


def test_a_leader_with_a_callback_has_no_channel_to_read_and_a_config_is_no_handler(
        sessions: Sessions, router: zenoh.Session, port: int) -> None:
    with Leader(sessions.node(port), SWARM, lambda _: None) as leader, \
            pytest.raises(TypeError, match="FifoChannel"):
        leader.recv(0)
    with pytest.raises(TypeError, match="not LeaderConfig"):
        Leader(sessions.node(port), SWARM, LeaderConfig())  # type: ignore[arg-type]


def test_an_observer_sees_stats_and_deliveries_typed(
        sessions: Sessions, router: zenoh.Session, port: int) -> None:
    seen = FifoChannel[object](10_000)
    with Observer(sessions.node(port), SWARM, seen) as observer, \
            Follower(sessions.node(port), SWARM, "uav2", sampler=lambda: b"x"), \
            Leader(sessions.node(port), SWARM, config=LeaderConfig(policy="round-robin")):
        kinds: set[type] = set()
        for observation in seen:
            kinds.add(type(observation))
            if kinds == {LeaderSummary, FollowerStats, DeliveryRecord} and \
                    observer.leader is not None and observer.leader.followers == ["uav2"] \
                    and observer.followers["uav2"].deliveries > 0:
                break
        leader = observer.leader
        stats = observer.followers["uav2"]
    assert leader.policy == "round-robin" and leader.polls_per_s > 0
    assert stats.follower == "uav2" and stats.deliveries > 0 and stats.present


def test_an_observer_skips_what_does_not_parse(
        sessions: Sessions, router: zenoh.Session, port: int) -> None:
    seen = FifoChannel[object](16)
    publisher = sessions.node(port)
    with Observer(sessions.node(port), SWARM, seen) as watching:
        wait_until_known(publisher, f"wiswarm/{SWARM}/leader/stats")
        publisher.put(f"wiswarm/{SWARM}/leader/stats", b"not json")
        publisher.put(f"wiswarm/{SWARM}/f9/stats", b'{"follower": "f9", "polls": "many"}')
        publisher.put(f"wiswarm/{SWARM}/f9/stats", b'{"follower": "f9", "polls": 3}')
        stats = seen.recv(WAIT)
        wait_until_known(publisher, f"wiswarm/{SWARM}/leader/deliveries")
        publisher.put(f"wiswarm/{SWARM}/leader/deliveries", json.dumps([
            {"follower": "f9", "outcome": "timeout", "generated_at": 1.0, "delivered_at": 2.0},
            {"follower": "f9", "outcome": "delivered", "generated_at": 1.0, "delivered_at": 2.0},
        ]))
        record = seen.recv(WAIT)
    assert isinstance(stats, FollowerStats) and stats.polls == 3 and math.isnan(stats.aoi_s)
    assert record == DeliveryRecord("f9", "delivered", 1.0, 2.0)
    assert watching.bad_input.total() == 3
