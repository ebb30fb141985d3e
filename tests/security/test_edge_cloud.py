"""Two sites and a cloud secured by ``wiswarm security init --site``: real sessions on
loopback TLS. One deployment for the module (the three routers, the sites' followers
and edge leaders); each test brings its own cloud leader and rogues."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
import zenoh

from tests.transport.helpers import Recorder
from wiswarm_zenoh.core import Waypoint
from wiswarm_zenoh.security import pki
from wiswarm_zenoh.security.acl import Roster
from wiswarm_zenoh.security.deploy import Plan, SitePlan, init
from wiswarm_zenoh.transport import FollowerNode, LeaderNode, SwarmKeys
from wiswarm_zenoh.transport.edge import Upstream
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port
from wiswarm_zenoh.usage import UsageError

from .helpers import WAIT, Inbox, Sessions, answer, replies, until

CLOUD = "cloud"
SITES = {"s1": ("uav1", "uav2"), "s2": ("uav1",)}
PAIRS = [f"{site}.{f}" for site, followers in SITES.items() for f in followers]
KEYS = SwarmKeys(CLOUD)
POLLS = 20  # polls of a pair a rogue would have had its share of


def _sample() -> bytes:
    return bytes(500)


@dataclass
class Deployment:
    """The routers, followers and edge leaders up; what the followers were told."""

    sessions: Sessions
    ports: dict[str | None, int]
    edges: dict[str, tuple[LeaderNode, Upstream]] = field(default_factory=dict)
    obeyed: list[tuple[str, list[Waypoint]]] = field(default_factory=list)
    told: threading.Condition = field(default_factory=threading.Condition)

    def endpoint(self, site: str | None) -> str:
        return f"tls/127.0.0.1:{self.ports[site]}"

    def edge(self, site: str, name: str) -> tuple[LeaderNode, Upstream]:
        session = self.sessions.open("leader", site)
        upstream = Upstream(session, CLOUD, site)
        node = LeaderNode(session, site, name=name, on_join=upstream.on_join,
                          on_leave=upstream.on_leave, on_delivery=upstream.on_delivery,
                          on_role=upstream.on_role)
        upstream.set_control = node.set_control
        return node, upstream

    def follower(self, site: str, follower: str) -> FollowerNode:
        def on_control(entry: list[Waypoint]) -> None:
            with self.told:
                self.obeyed.append((f"{site}.{follower}", entry))
                self.told.notify_all()

        return FollowerNode(self.sessions.open(follower, site), site, follower,
                            sample_on_poll=_sample, on_control=on_control)

    def cloud_leader(self, name: str = "cloud") -> tuple[LeaderNode, Recorder]:
        recorder = Recorder()
        return LeaderNode(self.sessions.open("leader"), CLOUD, name=name,
                          **recorder.callbacks()), recorder


@pytest.fixture(scope="module")
def deployment(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Deployment]:
    directory = tmp_path_factory.mktemp("deployment")
    ports = {site: free_tcp_port() for site in (None, *SITES)}
    cloud = (f"tls/127.0.0.1:{ports[None]}",)
    init(directory, Plan(Roster(CLOUD, "leader", (), ("ground",)), days=1, listen=cloud,
                         connect=cloud, sites=tuple(SitePlan(site, followers, ports[site])
                                                    for site, followers in SITES.items())))
    deployed = Deployment(Sessions(directory), ports)
    try:
        deployed.sessions.open("router")
        for site, followers in SITES.items():
            deployed.sessions.open("router", site, listen=(deployed.endpoint(site),))
            for follower in followers:
                deployed.follower(site, follower)
            deployed.edges[site] = deployed.edge(site, f"edge-{site}")
        yield deployed
    finally:
        for node, upstream in deployed.edges.values():
            node.close()
            upstream.close()
        deployed.sessions.close_all()


def _delivered(recorder: Recorder, pairs: list[str], more: int = POLLS) -> None:
    """Until each of ``pairs`` was delivered ``more`` times from now."""
    base = {pair: recorder.count(pair) for pair in pairs}
    recorder.wait(f"{more} deliveries of each of {pairs}",
                  lambda r: all(r.count(p) >= base[p] + more for p in pairs))


def test_the_secured_deployment_delivers_both_sites_to_the_cloud(
        deployment: Deployment) -> None:
    ground = deployment.sessions.open("ground")  # an observer at the cloud reads stats
    stats = Inbox(ground, KEYS.all_stats)
    cloud, recorder = deployment.cloud_leader()
    with cloud:
        _delivered(recorder, PAIRS)
        assert sorted(cloud.followers) == sorted(PAIRS)
        waypoints = [(1.0, 2.0, 3.0, 4.0)]
        cloud.set_control("s2.uav1", waypoints)  # down through site 2's edge leader
        with deployment.told:
            assert deployment.told.wait_for(
                lambda: ("s2.uav1", waypoints) in deployment.obeyed, WAIT)
        with stats.cond:
            assert stats.cond.wait_for(lambda: any(
                json.loads(p).get("follower") == "s2.uav1" for p in stats.payloads), WAIT)
        assert cloud.bad_input.total() == 0


class Polled:
    """A queryable that counts the polls it gets and answers them."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self.count = 0
        self._queryable = session.declare_queryable(key, self._on_query)

    def _on_query(self, query: zenoh.Query) -> None:
        with query:
            self.count += 1
            query.reply(query.key_expr, b"rogue")


def _as_site_2s_router(deployment: Deployment) -> zenoh.Session:
    """A client of the cloud's router with site 2's router's certificate and password."""
    site2 = deployment.sessions.directory / "s2"
    config = _config(site2 / "leader.json5")
    tls = config["transport"]["link"]["tls"]
    for key in ("connect_certificate", "connect_private_key"):
        tls[key] = tls[key].replace("/leader", "/router")
    login = _config(site2 / "router.json5")["transport"]["auth"]["usrpwd"]
    config["transport"]["auth"]["usrpwd"] = {k: login[k] for k in ("user", "password")}
    config["connect"]["endpoints"] = [deployment.endpoint(None)]
    session = zenoh.open(zenoh.Config.from_json5(json.dumps(config)))
    deployment.sessions.opened.append(session)
    return session


def _config(path: Path) -> dict[str, Any]:
    return dict(json.loads(path.read_text().split("\n", 1)[1]))


def test_site_2s_certificates_never_answer_the_cloud_for_site_1(
        deployment: Deployment) -> None:
    """Site 2's edge leader's certificate at its own router, and site 2's router's
    certificate at the cloud's (a stolen edge box): a queryable on ``s1.uav1`` gets
    none of the cloud's polls. At the cloud's router and at site 1's, the edge leader
    is not even let in: their password files do not list it."""
    open_ = deployment.sessions.open
    at_site2 = open_("leader", "s2")
    for elsewhere in (None, "s1"):
        with pytest.raises(UsageError, match="no router answered"):
            open_("leader", "s2", connect=(deployment.endpoint(elsewhere),))
    stolen = [at_site2, _as_site_2s_router(deployment)]
    rogues = [Polled(session, KEYS.update("s1.uav1")) for session in stolen]
    # What site 2 may serve, declared after: once the cloud has its answer, the rogue
    # declarations before it (same links) were refused.
    acks = [answer(session, KEYS.update(f"s2.ack{i}"), b"ack")
            for i, session in enumerate(stolen)]
    cloud, recorder = deployment.cloud_leader()
    with cloud:
        probe = deployment.sessions.open("leader")
        for i in range(len(acks)):
            until(f"ack {i}", lambda i=i: b"ack" in replies(probe, KEYS.update(f"s2.ack{i}"), 1.0))
        _delivered(recorder, ["s1.uav1"])
        assert [rogue.count for rogue in rogues] == [0, 0]
        assert cloud.bad_input.total() == 0  # no reply of theirs came
    for queryable in acks:
        queryable.undeclare()


def test_a_site_1_follower_reads_and_polls_nothing_beyond_its_site(
        deployment: Deployment) -> None:
    """Nothing of site 2's swarm, nor the cloud's fresh data (which an observer reads
    meanwhile), and its polls of site 2's follower get nothing."""
    rogue = deployment.sessions.open("uav1", "s1")
    inboxes = [Inbox(rogue, key) for key in ("wiswarm/s2/**", KEYS.all_fresh, KEYS.everything)]
    # Its own site's control, subscribed after: once it comes, the router had refused
    # the subscriptions before it.
    control = Inbox(rogue, SwarmKeys("s1").control)
    fresh = Inbox(deployment.sessions.open("ground"), KEYS.all_fresh)
    cloud, recorder = deployment.cloud_leader()
    with cloud:
        with control.cond:
            assert control.cond.wait_for(lambda: control.payloads, WAIT)
        _delivered(recorder, PAIRS)
        with fresh.cond:  # the cloud's fresh data flowed meanwhile, and site 2 polled
            assert fresh.cond.wait_for(lambda: len(fresh.payloads) >= POLLS, WAIT)
        for key in ("wiswarm/s2/uav1/update", KEYS.update("s2.uav1"), KEYS.update("s1.uav1")):
            assert replies(rogue, key, timeout=1.0) == [], key
    assert [inbox.payloads for inbox in inboxes] == [[], [], []]


def _foreign(config: dict[str, Any], directory: Path, other: pki.Authority, name: str,
             trust_ours: bool) -> dict[str, Any]:
    """``config`` with a certificate of ``other`` (a CA of its own) named ``name``, and
    trusting that CA, or still the deployment's (so that it accepts the router)."""
    cert, key = pki.write_pair(directory, name.replace("/", "-"), *pki.issue(other, name, 1))
    tls = config["transport"]["link"]["tls"]
    for side in ("connect", "listen"):
        if f"{side}_certificate" in tls:
            tls.update({f"{side}_certificate": str(cert), f"{side}_private_key": str(key)})
    if not trust_ours:
        tls["root_ca_certificate"] = str(directory / "other-ca.pem")
    return config


@pytest.mark.parametrize("trust_ours", [False, True])
def test_a_router_and_a_node_of_another_ca_cannot_join_the_clouds_router(
        deployment: Deployment, tmp_path: Path, trust_ours: bool) -> None:
    top = deployment.sessions.directory
    other = pki.new_authority("other", 1)
    pki.write_pair(tmp_path, "other-ca", other.cert, other.key)
    router = _foreign(_config(top / "s1" / "router.json5"), tmp_path, other, "s1/router",
                      trust_ours)
    router["listen"]["endpoints"] = [f"tls/127.0.0.1:{free_tcp_port()}"]
    # Open only once joined: the wait is the open's own timeout.
    router["connect"].update(exit_on_failure=True, timeout_ms=1000)
    node = _foreign(_config(top / "leader.json5"), tmp_path, other, "leader", trust_ours)
    for config in (router, node):
        with pytest.raises(zenoh.ZError, match="Unable to connect"):
            zenoh.open(zenoh.Config.from_json5(json.dumps(config)))


def test_a_standby_cloud_leader_takes_over(deployment: Deployment) -> None:
    active, first = deployment.cloud_leader("cloud-a")
    standby, second = deployment.cloud_leader("cloud-b")  # started later: stands by
    with standby:
        try:
            _delivered(first, PAIRS, 5)
            assert active.active and not standby.active
        finally:
            active.close()
        _delivered(second, PAIRS, 5)
        assert standby.active


def test_a_standby_edge_leader_takes_over_serving_the_cloud(deployment: Deployment) -> None:
    standby = deployment.edge("s1", "edge-s1-b")
    active = deployment.edges.pop("s1")
    deployment.edges["s1"] = standby
    cloud, recorder = deployment.cloud_leader()
    with cloud:
        try:
            _delivered(recorder, PAIRS, 5)
            assert active[0].active and not standby[0].active
        finally:
            for part in active:
                part.close()
        _delivered(recorder, ["s1.uav1", "s1.uav2"], 5)
        assert standby[0].active and sorted(standby[1].followers) == ["s1.uav1", "s1.uav2"]


def test_a_site_hears_nothing_of_another_sites_control(deployment: Deployment) -> None:
    """The cloud's waypoints for site 1 go on ``control/s1``, which no rule lets reach
    site 2: site 2's edge leader and follower, subscribed to every control key they can
    name, get none of them, while site 1's follower obeys its own and site 2's control
    flows to both."""
    cloud_keys = (KEYS.control, KEYS.site_control("s1"), KEYS.all_site_controls,
                  KEYS.everything, "**")
    edge, robot = deployment.sessions.open("leader", "s2"), deployment.sessions.open("uav1", "s2")
    spies = [Inbox(session, key) for session in (edge, robot)
             for key in (*cloud_keys, "wiswarm/s1/**")]
    # Each session's own control, subscribed after the spies (same link): once it flows,
    # the router had taken or refused every spy's subscription.
    witnesses = [Inbox(edge, KEYS.site_control("s2")), Inbox(robot, SwarmKeys("s2").control)]
    cloud, recorder = deployment.cloud_leader()
    with cloud:
        _delivered(recorder, PAIRS)
        ours, theirs = [(5.0, 6.0, 7.0, 8.0)], [(1.0, 1.0, 1.0, 1.0)]
        cloud.set_control("s1.uav1", theirs)
        cloud.set_control("s2.uav1", ours)
        with deployment.told:
            assert deployment.told.wait_for(lambda: ("s1.uav1", theirs) in deployment.obeyed
                                            and ("s2.uav1", ours) in deployment.obeyed, WAIT)
        for witness in witnesses:  # a few repeats more of the control (every 0.1 s)
            with witness.cond:
                heard = len(witness.payloads)
                assert witness.cond.wait_for(lambda w=witness, n=heard: len(w.payloads) >= n + 3,
                                             WAIT)
    leaked = [p for spy in spies for p in spy.payloads if b"s1.uav1" in p]
    assert leaked == []
