"""What ``init --site``, ``add-follower --site`` and ``add-site`` write for a deployment
of sites and a cloud: certificates, configs, and each router's rules."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from cryptography import x509

from wiswarm_zenoh.cli.main import main
from wiswarm_zenoh.options import UsageError
from wiswarm_zenoh.security import pki
from wiswarm_zenoh.security.checks import check_identity
from wiswarm_zenoh.security.deploy import load
from wiswarm_zenoh.transport import SessionSpec, SwarmKeys

from .helpers import follower_permissions, init_sites, said_in_one_line

CLOUD, S1, S2 = SwarmKeys("cloud"), SwarmKeys("s1"), SwarmKeys("s2")
PORT = 17447


def _json5(path: Path) -> dict[str, Any]:
    """Our configs are JSON after their first (comment) line."""
    return dict(json.loads(path.read_text().split("\n", 1)[1]))


def _allowed(router: Path, common_name: str) -> set[tuple[str, str, str]]:
    """(message, flow, key) that ``router``'s rules allow ``common_name``."""
    acl = _json5(router)["access_control"]
    subjects = {s["id"] for s in acl["subjects"] if common_name in s["cert_common_names"]}
    ids = {r for p in acl["policies"] if set(p["subjects"]) & subjects for r in p["rules"]}
    return {(m, f, k) for r in acl["rules"] if r["id"] in ids for m in r["messages"]
            for f in r["flows"] for k in r["key_exprs"]}


@pytest.fixture
def pki_dir(tmp_path: Path) -> Path:
    return init_sites(tmp_path / "pki", PORT, "--site-hosts", "s2:10.0.0.2,site2.example")


def test_init_writes_the_cloud_at_the_top_and_each_site_in_its_directory(
        pki_dir: Path) -> None:
    ca = x509.load_pem_x509_certificate((pki_dir / "ca.pem").read_bytes())
    names = {None: ("router", "leader", "ground"), "s1": ("router", "leader", "uav1", "uav2"),
             "s2": ("router", "leader", "uav1")}
    for site, nodes in names.items():
        place = pki_dir if site is None else pki_dir / site
        assert (place / "ca.pem").read_bytes() == (pki_dir / "ca.pem").read_bytes()
        for node in nodes:
            cert = x509.load_pem_x509_certificate((place / f"{node}.pem").read_bytes())
            cert.verify_directly_issued_by(ca)  # one CA for the whole deployment
            assert pki.common_name(cert) == (node if site is None else f"{site}/{node}")
            SessionSpec(config_file=str(place / f"{node}.json5")).config()  # Zenoh takes it
    assert not (pki_dir / "s1" / "ca-key.pem").exists()
    cloud = [f"tls/127.0.0.1:{PORT}"]
    for k, site in enumerate(("s1", "s2"), start=1):
        router = _json5(pki_dir / site / "router.json5")
        assert router["connect"]["endpoints"] == cloud  # a site's router dials the cloud's
        assert router["listen"]["endpoints"] == [f"tls/0.0.0.0:{PORT + k}"]
        edge = _json5(pki_dir / site / "leader.json5")
        assert edge["metadata"]["wiswarm"] == {"swarm": site, "node": "leader",
                                               "upstream": "cloud"}
    assert _json5(pki_dir / "s2" / "uav1.json5")["connect"]["endpoints"] == [
        f"tls/10.0.0.2:{PORT + 2}", f"tls/site2.example:{PORT + 2}"]
    router2 = x509.load_pem_x509_certificate((pki_dir / "s2" / "router.pem").read_bytes())
    sans = router2.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert "site2.example" in sans.get_values_for_type(x509.DNSName)
    assert _json5(pki_dir / "leader.json5")["connect"]["endpoints"] == cloud
    assert "connect" not in _json5(pki_dir / "router.json5")


def test_each_router_lets_a_site_serve_the_cloud_for_its_own_pairs_only(
        pki_dir: Path) -> None:
    cloud_router, s1_router = pki_dir / "router.json5", pki_dir / "s1" / "router.json5"
    serving = {("declare_queryable", "ingress", f"{CLOUD.prefix}/s1.$*/update"),
               ("reply", "ingress", f"{CLOUD.prefix}/s1.$*/update"),
               ("query", "egress", f"{CLOUD.prefix}/s1.$*/update"),
               ("liveliness_token", "ingress", f"{CLOUD.prefix}/members/s1.$*"),
               ("declare_subscriber", "ingress", CLOUD.site_control("s1")),
               ("put", "egress", CLOUD.site_control("s1"))}  # site 1's control only
    # The cloud's router knows site 1 by its router's certificate only.
    assert _allowed(cloud_router, "s1/router") == serving
    for stranger in ("s1/leader", "s1/uav1", "s2/leader", "uav1"):
        assert _allowed(cloud_router, stranger) == set()
    # Site 1's router: its edge leader leads site 1 and serves as above; the cloud's
    # router gets the mirror of it.
    edge = _allowed(s1_router, "s1/leader")
    assert serving <= edge and ("query", "ingress", f"{S1.prefix}/*/update") in edge
    mirror = {(m, "egress" if f == "ingress" else "ingress", k) for m, f, k in serving}
    assert _allowed(s1_router, "router") == mirror
    # A follower of site 1 gets its own site's keys, as in a swarm of its own.
    assert _allowed(s1_router, "s1/uav1") == follower_permissions(S1, "uav1")
    for stranger in ("s2/leader", "s2/uav1", "s2/router", "leader", "ground"):
        assert _allowed(s1_router, stranger) == set()
    # The cloud's observers read the cloud's swarm, nothing of a site's.
    assert all(k.startswith(CLOUD.prefix + "/") or k.startswith("wiswarm/experiments/")
               for _, _, k in _allowed(cloud_router, "ground"))


def test_add_follower_and_add_site_rewrite_only_the_router_they_concern(
        pki_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = {p: p.read_bytes() for p in (pki_dir / "router.json5",
                                          pki_dir / "s2" / "router.json5")}
    assert main(["security", "add-follower", "--out", str(pki_dir), "--site", "s1",
                 "uav3"]) == 0
    assert f"{pki_dir}/s1/router.json5" in capsys.readouterr().out
    assert ("reply", "ingress", S1.update("uav3")) in _allowed(
        pki_dir / "s1" / "router.json5", "s1/uav3")
    assert all(p.read_bytes() == text for p, text in before.items())
    s2_router = (pki_dir / "s2" / "router.json5").read_bytes()
    assert main(["security", "add-site", "--out", str(pki_dir), "s3:uav1"]) == 0
    assert f"--swarm s3 --upstream cloud -c {pki_dir}/s3/leader.json5" in (
        capsys.readouterr().out)
    assert load(pki_dir).site("s3").port == PORT + 3
    assert ("query", "egress", f"{CLOUD.prefix}/s3.$*/update") in _allowed(
        pki_dir / "router.json5", "s3/router")
    assert (pki_dir / "s2" / "router.json5").read_bytes() == s2_router
    cert = x509.load_pem_x509_certificate((pki_dir / "s3" / "uav1.pem").read_bytes())
    assert pki.common_name(cert) == "s3/uav1"


@pytest.mark.parametrize(("argv", "message"), [
    (["--followers", "f1", "--site", "s1:f1"], "give --followers (one swarm) or --site"),
    ([], "give --followers (one swarm) or --site"),
    (["--site", "s.1:f1"], "must not contain ."),
    (["--site", "s1"], "expected SITE:F1,F2"),
    (["--site", "s1:f1", "--site", "s1:f2"], "s1 given twice"),
    (["--swarm", "c", "--site", "c:f1"], "c given twice"),
    (["--site", "s1:f1", "--site-hosts", "s2:h2"], "--site-hosts s2: no such site"),
    (["--site", "s1:router"], "routers, leader, followers, observers"),
    (["--site", "s1:f1", "--port", "65535"], "site k's router listens on PORT + k"),
])
def test_bad_deployment_input_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str],
        message: str) -> None:
    code = main(["security", "init", "--out", str(tmp_path / "s"), *argv])
    said_in_one_line(code, capsys.readouterr().err, message)
    assert not (tmp_path / "s").exists()  # nothing written


@pytest.mark.parametrize(("argv", "message"), [
    (["add-follower", "uav9"], "name the follower's site with --site (s1, s2)"),
    (["add-follower", "--site", "s9", "uav9"], "no site 's9' here (sites: s1, s2)"),
    (["add-follower", "--site", "s1", "uav1"], "'uav1' is already in site 's1'"),
    (["add-site", "s1:uav9"], "s1 given twice"),
])
def test_bad_changes_to_a_deployment_are_one_line_and_exit_2(
        pki_dir: Path, capsys: pytest.CaptureFixture[str], argv: list[str],
        message: str) -> None:
    capsys.readouterr()
    action, *rest = argv
    code = main(["security", action, "--out", str(pki_dir), *rest])
    said_in_one_line(code, capsys.readouterr().err, message)


@pytest.mark.parametrize(("config", "flags", "message"), [
    ("s1/leader", ["--swarm", "s1"], "pass --upstream cloud"),
    ("s1/leader", ["--swarm", "s1", "--upstream", "other"], "pass --upstream cloud"),
    ("s1/leader", ["--swarm", "s1", "--upstream", "cloud", "--site", "s2"],
     "serve 'cloud' as 's1' only"),
    ("leader", ["--swarm", "cloud", "--upstream", "other"], "leave out --upstream"),
])
def test_a_leader_whose_rules_do_not_cover_its_upstream_is_one_line(
        pki_dir: Path, capsys: pytest.CaptureFixture[str], config: str, flags: list[str],
        message: str) -> None:
    """It would run, and the cloud would never hear from it."""
    capsys.readouterr()
    code = main(["leader", "-c", str(pki_dir / f"{config}.json5"), *flags])
    said_in_one_line(code, capsys.readouterr().err, message)


def test_a_site_followers_certificate_is_its_own_and_no_other_sites(pki_dir: Path) -> None:
    check_identity(str(pki_dir / "s1" / "uav1.json5"), "uav1")
    with pytest.raises(UsageError, match="is s1/uav1's, not uav2's"):
        check_identity(str(pki_dir / "s1" / "uav1.json5"), "uav2")
