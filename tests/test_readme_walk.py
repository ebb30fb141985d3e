"""The walk a newcomer takes through the README and the guides it links to
(docs/getting-started.md, docs/guides/swarm.md, security.md, dashboard.md,
standby-edge-cloud.md, testbed.md), each command
a process of its own started as the pages say: the parts that fit in CI time. A run
with no fault must show no traceback, no WARNING or ERROR line (ours or Zenoh's) and at
most 10 log lines per process per minute; each misstep a newcomer makes must be named
in its one line.

Covered: a swarm by hand (router, leader, two followers), a secured swarm (``wiswarm
security init``) with an observer's dashboard, a short demo on loopback, two sites and a
cloud step by step (three routers, a cloud and two edge leaders, a follower a site),
open and secured (``security init --site``), a short testbed study where root is there;
and the missteps: no router where the leader or a follower is pointed (said after 3 s,
and at the end, exit code 1), a plain endpoint at a TLS router, a dashboard port in use.
(The demo's comparison over the shared link has tests of its own.)"""

from __future__ import annotations

import os
import re
import socket
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import pytest

from wiswarm_zenoh.testbed import TestbedUnavailable, check_available
from wiswarm_zenoh.testbed.faults import Process
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

RUN = 8.0  # seconds a node runs (--duration)
NOISE = re.compile(r"\bWARN(ING)?\b|\bERROR\b|Traceback")
# Zenoh 1.10's own race, not ours, seen about once in ten starts of a peer: a query that
# overtakes the declaration of its key expression is dropped with this ERROR (the poll
# then goes unanswered, as any lost one). Known, counted as no fault here.
ZENOH_RACE = "Received Query for unknown key_expr"
LOG_LINE = re.compile(r"^\d{4}-\d\d-\d\d[ T]\d\d:\d\d:\d\d")  # ours and Zenoh's


class Node(Process):
    """A ``wiswarm`` command as a user starts it (``Process``), timed from its start."""

    def __init__(self, argv: Sequence[str]) -> None:
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        env.pop("RUST_LOG", None)
        self.argv = list(argv)
        self.started = time.monotonic()
        super().__init__(argv[0], argv, env)

    def finish(self, timeout: float = 60.0) -> int:
        code = self.popen.wait(timeout)
        self.read_to_end(timeout)
        return code

    def quiet(self) -> None:
        """No traceback, WARNING or ERROR, and at most 10 log lines a minute."""
        noisy = [line for line in self.lines if NOISE.search(line) and ZENOH_RACE not in line]
        assert not noisy, f"{' '.join(self.argv[:3])}: {noisy[:5]}"
        minutes = max(time.monotonic() - self.started, 60.0) / 60.0
        logged = [line for line in self.lines if LOG_LINE.match(line)]
        assert len(logged) <= 10 * minutes, f"{' '.join(self.argv[:3])}: {logged[:12]}"


@contextmanager
def nodes() -> Iterator[list[Node]]:
    started: list[Node] = []
    try:
        yield started
    finally:
        for node in reversed(started):
            node.stop()


def _listen(port: int) -> list[str]:
    return ["-l", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"]


def _endpoint(port: int) -> list[str]:
    return ["-e", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"]


def test_a_swarm_by_hand_runs_quietly(tmp_path: Path) -> None:
    port = free_tcp_port()
    with nodes() as started:
        # until stopped (SIGTERM: as Ctrl-C), after the others
        router = Node(["router", "-l", f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"])
        started.append(router)
        router.wait_for("listening")
        leader = Node(["leader", *_endpoint(port), "--duration", str(RUN)])
        followers = [Node(["follower", "--id", f"uav{i}", *_endpoint(port), "--duration",
                           str(RUN)]) for i in (1, 2)]
        started += [leader, *followers]
        for node in (leader, *followers):
            assert node.finish() == 0, node.lines[-5:]
        assert any("uav1" in line for line in leader.lines)  # its summary table
        router.stop()
    for node in started:
        node.quiet()


def test_a_secured_swarm_with_an_observers_dashboard_runs_quietly(tmp_path: Path) -> None:
    port = free_tcp_port()
    pki = tmp_path / "swarm-pki"
    init = Node(["security", "init", "--out", str(pki), "--followers", "uav1",
                 "--observers", "ground", "--port", str(port),
                 "--listen", f"tls/127.0.0.1:{port}"])
    assert init.finish() == 0, init.lines
    web = free_tcp_port()
    with nodes() as started:
        router = Node(["router", "-c", str(pki / "router.json5")])
        started.append(router)
        router.wait_for("listening")
        leader = Node(["leader", "-c", str(pki / "leader.json5"), "--duration", str(RUN)])
        follower = Node(["follower", "--id", "uav1", "-c", str(pki / "uav1.json5"),
                         "--duration", str(RUN)])
        dashboard = Node(["dashboard", "-c", str(pki / "ground.json5"), "--port", str(web),
                          "--duration", str(RUN)])
        started += [leader, follower, dashboard]
        for node in (leader, follower, dashboard):
            assert node.finish() == 0, node.lines[-5:]
        router.stop()
    for node in started:
        node.quiet()  # the router shows every refusal: none


def test_a_short_demo_on_loopback_runs_quietly(tmp_path: Path) -> None:
    demo = Node(["demo", "--channel", "none", "--system", "wiswarm", "--uavs", "2",
                 "--duration", "4", "--warmup", "1", "--no-dashboard", "--no-gif",
                 "--no-live", "--out", str(tmp_path / "runs")])
    assert demo.finish(120.0) == 0, demo.lines[-8:]
    demo.quiet()


def test_a_short_testbed_study_runs_quietly(tmp_path: Path) -> None:
    """The README's study, at its smallest: N = 2, every system, one best-rate point."""
    try:
        check_available()
    except TestbedUnavailable as exc:
        pytest.skip(f"testbed unavailable: {exc}")
    study = Node(["experiment", "testbed", "--ns", "2", "--search", "grid", "--rates", "25",
                  "--duration", "2", "--warmup", "1", "--out", str(tmp_path / "study")])
    assert study.finish(240.0) == 0, study.lines[-8:]
    study.quiet()
    gains = (tmp_path / "study" / "gains.md").read_text()
    assert "- nothing: every process ran to the end and stopped cleanly" in gains, gains


def _the_cloud_gets_both_sites(started: list[Node], routers: list[Node], leaders: list[Node],
                               followers: list[Node]) -> None:
    """The leaders (the cloud's first) and followers run to their end, the cloud's table
    lists both sites' followers; then the routers stop."""
    started += [*leaders, *followers]
    for node in (*leaders, *followers):
        assert node.finish() == 0, node.lines[-5:]
    summary = "\n".join(leaders[0].lines)
    assert "s1.uav1" in summary and "s2.uav1" in summary, leaders[0].lines[-8:]
    for router in reversed(routers):
        router.stop()


def test_two_sites_and_a_cloud_step_by_step_run_quietly(tmp_path: Path) -> None:
    cloud, site1, site2 = (free_tcp_port() for _ in range(3))
    with nodes() as started:
        # routers until stopped, after the others
        routers = [Node(["router", *_listen(cloud)])]
        routers[0].wait_for("listening")
        routers += [Node(["router", *_listen(site), "-e", f"tcp/127.0.0.1:{cloud}"])
                    for site in (site1, site2)]
        started += routers
        for router in routers[1:]:
            router.wait_for("listening")
        run = ["--duration", str(RUN)]
        leaders = [Node(["leader", "--swarm", "cloud", "--in-flight", "6", *_endpoint(cloud),
                         *run])]
        leaders += [Node(["leader", "--swarm", f"site{i}", "--upstream", "cloud", "--site",
                          f"s{i}", *_endpoint(port), *run])
                    for i, port in ((1, site1), (2, site2))]
        followers = [Node(["follower", "--swarm", f"site{i}", "--id", "uav1",
                           *_endpoint(port), *run]) for i, port in ((1, site1), (2, site2))]
        _the_cloud_gets_both_sites(started, routers, leaders, followers)
    for node in started:
        node.quiet()


def test_two_sites_and_a_cloud_secured_step_by_step_run_quietly(tmp_path: Path) -> None:
    """As security.md's walkthrough, the routers on free ports (``-l``, ``-e`` over the
    configs'): the routers refuse nothing, so they say nothing."""
    cloud, *sites = (free_tcp_port() for _ in range(3))
    pki = tmp_path / "pki"
    init = Node(["security", "init", "--out", str(pki), "--swarm", "cloud", "--site",
                 "s1:uav1", "--site", "s2:uav1", "--port", str(cloud),
                 "--listen", f"tls/127.0.0.1:{cloud}"])
    assert init.finish() == 0, init.lines
    here = {f"s{i}": ["-e", f"tls/127.0.0.1:{port}"] for i, port in enumerate(sites, 1)}
    with nodes() as started:
        routers = [Node(["router", "-c", str(pki / "router.json5")])]
        routers[0].wait_for("listening")
        routers += [Node(["router", "-c", str(pki / site / "router.json5"), "-l",
                          f"tls/127.0.0.1:{port}"]) for site, port in zip(here, sites, strict=True)]
        started += routers
        for router in routers[1:]:
            router.wait_for("listening")
        run = ["--duration", str(RUN)]
        leaders = [Node(["leader", "--swarm", "cloud", "--in-flight", "6", "-c",
                         str(pki / "leader.json5"), *run])]
        leaders += [Node(["leader", "--swarm", site, "--upstream", "cloud", "-c",
                          str(pki / site / "leader.json5"), *endpoint, *run])
                    for site, endpoint in here.items()]
        followers = [Node(["follower", "--swarm", site, "--id", "uav1", "-c",
                           str(pki / site / "uav1.json5"), *endpoint, *run])
                     for site, endpoint in here.items()]
        _the_cloud_gets_both_sites(started, routers, leaders, followers)
    for node in started:
        node.quiet()


def test_no_router_where_the_leader_is_pointed_is_named_in_one_line(tmp_path: Path) -> None:
    port = free_tcp_port()  # nothing listens there
    leader = Node(["leader", *_endpoint(port), "--duration", "5"])
    line = leader.wait_for("no router reached")
    assert f"tcp/127.0.0.1:{port}" in line and "wiswarm router" in line
    assert leader.finish() == 1  # and at its end, that none ever was


def test_a_client_started_before_its_router_waits_for_it_and_joins() -> None:
    """Given -e, a node is a client, which Zenoh opens only once its router answers:
    started first (robots and ground boot in any order), it waits, says so once, and
    joins when the router comes."""
    port = free_tcp_port()
    with nodes() as started:
        follower = Node(["follower", "--swarm", "late", "--id", "uav1", *_endpoint(port)])
        started.append(follower)
        follower.wait_for("no router reached", f"tcp/127.0.0.1:{port}")
        assert not follower.said("Ctrl-C to stop")  # still waiting at its open
        started.append(Node(["router", *_listen(port)]))
        follower.wait_for("router reached, after")
        follower.wait_for("Ctrl-C to stop")
        leader = Node(["-v", "leader", "--swarm", "late", *_endpoint(port)])
        started.append(leader)
        leader.wait_for("follower uav1 joined")
    for node in started:
        assert not any("Traceback" in line for line in node.lines), "\n".join(node.lines)


@pytest.mark.parametrize("system", ["wiswarm", "push"])
def test_a_follower_that_never_reached_a_router_says_so_and_fails(system: str) -> None:
    port = free_tcp_port()  # nothing listens there
    follower = Node(["follower", "--id", "uav1", "--system", system, *_endpoint(port),
                     "--duration", "1.5"])
    assert follower.finish() == 1, follower.lines[-5:]
    said = [line for line in follower.lines if "no router was ever reached" in line]
    assert len(said) == 1 and f"tcp/127.0.0.1:{port}" in said[0], follower.lines[-5:]
    assert not any("Traceback" in line for line in follower.lines)


def test_a_plain_endpoint_at_a_tls_router_is_named_on_both_sides(tmp_path: Path) -> None:
    port = free_tcp_port()
    pki = tmp_path / "swarm-pki"
    assert Node(["security", "init", "--out", str(pki), "--followers", "uav1", "--port",
                 str(port), "--listen", f"tls/127.0.0.1:{port}"]).finish() == 0
    with nodes() as started:
        router = Node(["router", "-c", str(pki / "router.json5")])
        started.append(router)
        router.wait_for("listening")
        leader = Node(["leader", "-m", "peer", *_endpoint(port), "--duration", "6"])
        started.append(leader)
        assert "tls/HOST:PORT" in leader.wait_for("no router reached")
        said = router.wait_for("without TLS")
        leader.finish()
        time.sleep(1.0)  # Zenoh retries every 0.5 s: the router must not say it again
        router.stop()
    assert sum("without TLS" in line for line in router.lines) == 1, said


def test_a_dashboard_port_in_use_is_named_at_once(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        # Its router is nowhere: had it opened its session first (scouting for seconds),
        # that would have been the error.
        dashboard = Node(["dashboard", "-m", "client", "-e", f"tcp/127.0.0.1:{free_tcp_port()}",
                          "--port", str(port), "--duration", "5"])
        assert dashboard.finish(30.0) == 2
    assert any(f"port {port}" in line and "in use" in line for line in dashboard.lines)
    assert not any("Zenoh session" in line for line in dashboard.lines)
