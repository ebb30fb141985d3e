"""What ``init`` and ``add-follower`` write: certificates, keys, rules and configs."""

from __future__ import annotations

import json
import stat
from pathlib import Path
from typing import Any

import pytest
import zenoh
from cryptography import x509

from wiswarm_zenoh.cli.main import main
from wiswarm_zenoh.security import pki
from wiswarm_zenoh.security.configs import render
from wiswarm_zenoh.security.deploy import add_follower, load
from wiswarm_zenoh.transport import SessionSpec

from .helpers import KEYS, Sessions, answer, follower_permissions, replies, until


def _json5(path: Path) -> dict[str, Any]:
    """Our configs are JSON after their first (comment) line."""
    return dict(json.loads(path.read_text().split("\n", 1)[1]))


def _rules_of(config: dict[str, Any], common_name: str) -> list[dict[str, Any]]:
    acl = config["access_control"]
    subjects = {s["id"] for s in acl["subjects"] if common_name in s["cert_common_names"]}
    ids = {r for p in acl["policies"] if set(p["subjects"]) & subjects for r in p["rules"]}
    return [rule for rule in acl["rules"] if rule["id"] in ids]


def _allowed(rules: list[dict[str, Any]]) -> set[tuple[str, str, str]]:
    return {(m, f, k) for r in rules for m in r["messages"] for f in r["flows"]
            for k in r["key_exprs"]}


def test_init_writes_a_ca_a_certificate_per_node_and_client_configs(swarm: Path) -> None:
    ca = x509.load_pem_x509_certificate((swarm / "ca.pem").read_bytes())
    for name in ("router", "leader", "f1", "f2", "o1", "o2"):
        cert = x509.load_pem_x509_certificate((swarm / f"{name}.pem").read_bytes())
        assert pki.common_name(cert) == name
        cert.verify_directly_issued_by(ca)
        sans = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
        assert "localhost" in sans.get_values_for_type(x509.DNSName)
        assert stat.S_IMODE((swarm / f"{name}-key.pem").stat().st_mode) == 0o600
    assert stat.S_IMODE((swarm / "ca-key.pem").stat().st_mode) == 0o600
    for name in ("leader", "f1", "o1"):
        config = _json5(swarm / f"{name}.json5")
        tls = config["transport"]["link"]["tls"]
        assert config["mode"] == "client"
        assert config["scouting"]["multicast"]["enabled"] is False
        assert config["transport"]["shared_memory"]["enabled"] is False
        assert tls["connect_certificate"] == str(swarm.resolve() / f"{name}.pem")
        assert all(Path(p).is_absolute() for p in tls.values() if isinstance(p, str))
        SessionSpec(config_file=str(swarm / f"{name}.json5")).config()  # Zenoh takes it
    router = _json5(swarm / "router.json5")
    assert router["mode"] == "router" and router["transport"]["link"]["protocols"] == ["tls"]
    assert router["transport"]["link"]["tls"]["enable_mtls"] is True
    assert router["access_control"]["default_permission"] == "deny"


def test_the_rules_give_each_role_what_it_needs_and_no_more(swarm: Path) -> None:
    router = _json5(swarm / "router.json5")
    f1 = _allowed(_rules_of(router, "f1"))
    assert f1 == follower_permissions(KEYS, "f1")
    observer = _allowed(_rules_of(router, "o1"))  # read-only: what the dashboard and
    assert {m for m, f, _ in observer if f == "ingress"} == {  # wiswarm record read
        "declare_subscriber", "declare_liveliness_subscriber", "liveliness_query"}
    assert {k for m, f, k in observer if m == "declare_subscriber"} == {
        KEYS.all_stats, KEYS.leader_stats, KEYS.all_fresh, f"{KEYS.prefix}/leader/deliveries",
        f"{KEYS.prefix}/*/tracking", "wiswarm/experiments/*/points"}
    assert {f for m, f, _ in observer if m in ("put", "liveliness_token")} == {"egress"}
    leader = _allowed(_rules_of(router, "leader"))
    assert {k for m, f, k in leader if (m, f) == ("put", "ingress")} == {
        KEYS.control, KEYS.all_site_controls, KEYS.all_stats, KEYS.leader_stats,
        KEYS.all_fresh, f"{KEYS.prefix}/leader/deliveries",
        KEYS.all_weights}  # weights: its side's tools; control/<site>: a cloud's
    assert ("liveliness_token", "ingress", KEYS.leaders) in leader
    # a standby follows the active leader: it may hear control and stats, not put stats
    assert ("declare_subscriber", "ingress", KEYS.control) in leader
    assert ("put", "egress", KEYS.leader_stats) in leader


def test_add_follower_signs_with_the_same_ca_and_the_router_lets_it_serve(
        swarm: Path, sessions: Sessions) -> None:
    add_follower(swarm, "f3")
    assert load(swarm).roster.followers == ("f1", "f2", "f3")
    assert _allowed(_rules_of(_json5(swarm / "router.json5"), "f3"))
    sessions.open("router")  # started after add-follower, so with f3 in its rules
    leader, f3 = sessions.open("leader"), sessions.open("f3")
    queryable = answer(f3, KEYS.update("f3"), b"f3")
    until("f3 answers a poll", lambda: replies(leader, KEYS.update("f3"), 1.0) == [b"f3"])
    queryable.undeclare()


@pytest.mark.parametrize(("argv", "message"), [
    (["--followers", "f1,f1"], "f1 given twice"),
    (["--followers", "f1", "--observers", "f1"], "f1 given twice"),
    (["--followers", "f/1"], "must not contain /"),
    (["--followers", "f1", "--listen", "tcp/0.0.0.0:7447"], "must be a tls/HOST:PORT"),
    (["--followers", "f1", "--days", "0"], "--days: must be in [1, 36500], got 0"),
])
def test_bad_init_input_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str],
        message: str) -> None:
    assert main(["security", "init", "--out", str(tmp_path / "s"), *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "s").exists()  # nothing written


def test_add_follower_without_init_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["security", "add-follower", "--out", str(tmp_path), "f3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "security.json: not found" in err, err


def test_a_config_zenoh_refuses_is_never_rendered() -> None:
    with pytest.raises(zenoh.ZError):
        render({"access_control": {"enabled": True, "rules": [{"id": "no messages"}]}}, "x")


def test_a_ros2_leader_gets_its_ros2_keys_and_no_more(tmp_path: Path) -> None:
    """``--ros2``: the leader may put its topics, hear Paths and weights and hold its node's tokens
    (keys Zenoh accepts in a rule, ``@ros2_lv`` and ``%`` included); nobody else gets
    any ROS 2 key, and ``add-follower`` keeps them."""
    out = tmp_path / "pki"
    assert main(["security", "init", "--out", str(out), "--followers", "f1", "--swarm",
                 "s1", "--ros2", "--ros-domain", "3"]) == 0
    add_follower(out, "f2")
    router = _json5(out / "router.json5")
    leader = _allowed(_rules_of(router, "leader"))
    ros2 = {rule for rule in leader if rule[2][0].isdigit() or rule[2].startswith("@")}
    assert ros2 == {
        ("put", "ingress", "3/wiswarm/s1/*/*/*/*"), ("put", "ingress", "3/diagnostics/*/*"),
        ("declare_subscriber", "ingress", "3/wiswarm/s1/*/waypoints/*/*"),
        ("put", "egress", "3/wiswarm/s1/*/waypoints/*/*"),
        ("declare_subscriber", "ingress", "3/wiswarm/s1/*/weight/*/*"),
        ("put", "egress", "3/wiswarm/s1/*/weight/*/*"),
        ("liveliness_token", "ingress", "@ros2_lv/3/*/*/*/*/%/%wiswarm%s1/wiswarm_leader/**"),
        ("declare_subscriber", "egress", "3/wiswarm/s1/*/*/*/*"),
        ("declare_subscriber", "egress", "3/diagnostics/*/*")}
    for follower in ("f1", "f2"):
        keys = {k for _, _, k in _allowed(_rules_of(router, follower))}
        assert all(k.startswith("wiswarm/") for k in keys)
