"""An edge leader that is a follower upstream: a cloud leader polls (site, follower)
pairs through it, ages add up across the two hops, control flows down. Real sessions
on loopback."""

from __future__ import annotations

import struct
import threading
import time

import zenoh

from wiswarm_zenoh.core import Waypoint
from wiswarm_zenoh.core.wire import decode_control
from wiswarm_zenoh.transport import FollowerNode, LeaderNode
from wiswarm_zenoh.transport.edge import Upstream

from .helpers import WAIT, Recorder, Sessions

SITE_SKEW = 5.0  # the edge host's clock is 5 s ahead


def _stamped() -> bytes:
    """A frame carrying its true capture time (this host's clock), as the testbed's."""
    return struct.pack("<d", time.time()) + bytes(2000)


def test_a_cloud_leader_gets_each_sites_followers_with_their_true_ages(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    obeyed: list[list[Waypoint]] = []
    told = threading.Condition()

    def on_control(entry: list[Waypoint]) -> None:
        with told:
            obeyed.append(entry)
            told.notify_all()

    for fid in ("f1", "f2"):
        FollowerNode(sessions.node(port), "site1", fid, sample_on_poll=_stamped,
                     on_control=on_control if fid == "f1" else None)
    edge_session = sessions.node(port)

    def skewed() -> float:
        return time.time() + SITE_SKEW

    upstream = Upstream(edge_session, "cloud", "s1", clock=skewed)
    edge = LeaderNode(edge_session, "site1", clock=skewed, name="edge",
                      on_join=upstream.on_join, on_leave=upstream.on_leave,
                      on_delivery=upstream.on_delivery, on_role=upstream.on_role)
    upstream.set_control = edge.set_control
    try:
        with LeaderNode(sessions.node(port), "cloud", name="cloud",
                        **recorder.callbacks()) as cloud:
            for pair in ("s1.f1", "s1.f2"):
                recorder.wait(pair, lambda r, pair=pair: r.count(pair) >= 20)
            assert sorted(cloud.followers) == ["s1.f1", "s1.f2"]
            cloud.set_control("s1.f1", [(1.0, 2.0, 3.0, 4.0)])
            with told:
                assert told.wait_for(lambda: [(1.0, 2.0, 3.0, 4.0)] in obeyed, WAIT)
    finally:
        edge.close()
        upstream.close()
    for event in recorder.deliveries:
        made = struct.unpack_from("<d", event.payload)[0]  # the true time, cloud's clock
        # Each hop's clock estimate errs by up to its round trip's asymmetry: loopback.
        assert abs(event.generated_at - made) < 0.01, event
        assert 0.0 <= event.age < 1.0


def _edge(session: zenoh.Session, name: str, epoch: int) -> tuple[LeaderNode, Upstream]:
    upstream = Upstream(session, "cloud", "s1")
    edge = LeaderNode(session, "site1", name=name, epoch=epoch, on_join=upstream.on_join,
                      on_leave=upstream.on_leave, on_delivery=upstream.on_delivery,
                      on_role=upstream.on_role)
    upstream.set_control = edge.set_control
    return edge, upstream


def test_only_the_sites_active_edge_leader_serves_the_cloud(
    sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder
) -> None:
    """A standby edge leader serving the cloud too would answer each of its polls twice."""
    FollowerNode(sessions.node(port), "site1", "f1", sample_on_poll=_stamped)
    active_session = sessions.node(port)
    active, active_up = _edge(active_session, "edge-a", 1)
    standby, standby_up = _edge(sessions.node(port), "edge-b", 2)
    try:
        with LeaderNode(sessions.node(port), "cloud", name="cloud",
                        **recorder.callbacks()) as cloud:
            recorder.wait("served by the active edge", lambda r: r.count("s1.f1") >= 20)
            assert active.active and not standby.active
            assert active_up.followers == ["s1.f1"] and standby_up.followers == []
            assert cloud.bad_input.total() == 0  # no second reply to any poll
            active.close()
            active_up.close()
            active_session.close()  # edge-a goes: edge-b takes over, and serves
            before = recorder.count("s1.f1")
            recorder.wait("served by the new edge", lambda r: r.count("s1.f1") >= before + 20)
            assert standby.active and standby_up.followers == ["s1.f1"]
    finally:
        standby.close()
        standby_up.close()


def test_each_site_hears_only_its_own_control(
        sessions: Sessions, router: zenoh.Session, port: int, recorder: Recorder) -> None:
    """The cloud's waypoints for site 1's followers go on ``control/s1``, site 2's on
    ``control/s2``: what a site's router, edge leader or followers can subscribe to
    (``security`` allows each its own) holds nothing of another site's."""
    heard: dict[str, set[str]] = {}
    changed = threading.Condition()

    def snoop(sample: zenoh.Sample) -> None:
        entries = decode_control(sample.payload.to_bytes()).entries
        with changed:
            heard.setdefault(str(sample.key_expr), set()).update(entries)
            changed.notify_all()

    watcher = sessions.node(port)
    _held = watcher.declare_subscriber("wiswarm/cloud/control/**", snoop)
    _plain = watcher.declare_subscriber("wiswarm/cloud/control", snoop)
    for member in ("s1.f1", "s2.f1"):  # as the sites' edge leaders serve them upstream
        FollowerNode(sessions.node(port), "cloud", member, sample_on_poll=_stamped)
    with LeaderNode(sessions.node(port), "cloud", name="cloud",
                    **recorder.callbacks()) as cloud:
        recorder.wait("both sites", lambda r: r.count("s1.f1") > 0 and r.count("s2.f1") > 0)
        cloud.set_control("s1.f1", [(1.0, 1.0, 1.0, 1.0)])
        cloud.set_control("s2.f1", [(2.0, 2.0, 2.0, 2.0)])
        with changed:
            assert changed.wait_for(lambda: {"s1.f1"} <= heard.get(
                "wiswarm/cloud/control/s1", set()) and {"s2.f1"} <= heard.get(
                "wiswarm/cloud/control/s2", set()), WAIT)
    with changed:
        assert heard == {"wiswarm/cloud/control/s1": {"s1.f1"},
                         "wiswarm/cloud/control/s2": {"s2.f1"}}
