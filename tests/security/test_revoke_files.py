"""What ``revoke``, ``list`` and ``init --routers`` write and say: the revocation list,
the routers' rules and password files without the revoked, names never issued again,
and bad input in one line."""

from __future__ import annotations

import datetime
import json
import stat
from pathlib import Path
from typing import Any

import pytest
from cryptography import x509

from wiswarm_zenoh.cli.main import main

from .helpers import init_sites, said_in_one_line

PORT = 17600


def _json5(path: Path) -> dict[str, Any]:
    """Our configs are JSON after their first (comment) line."""
    return dict(json.loads(path.read_text().split("\n", 1)[1]))


def _subjects(router: Path) -> dict[str, dict[str, Any]]:
    """The router's subjects, by common name."""
    return {s["cert_common_names"][0]: s
            for s in _json5(router)["access_control"]["subjects"]}


def _users(place: Path) -> list[str]:
    return [line.split(":")[0] for line in (place / "users.txt").read_text().splitlines()]


def _snapshot(directory: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in directory.rglob("*") if p.is_file()}


@pytest.fixture
def pki_dir(tmp_path: Path) -> Path:
    return init_sites(tmp_path / "pki", PORT, "--routers", "2")


def test_two_routers_per_place_each_on_its_port_the_later_dialing_the_earlier(
        pki_dir: Path) -> None:
    cloud = [f"tls/127.0.0.1:{PORT}", f"tls/127.0.0.1:{PORT + 1}"]
    assert _json5(pki_dir / "leader.json5")["connect"]["endpoints"] == cloud
    assert "connect" not in _json5(pki_dir / "router.json5")
    assert _json5(pki_dir / "router2.json5")["connect"]["endpoints"] == cloud[:1]
    for k, site in enumerate(("s1", "s2"), start=1):
        port = PORT + 2 * k
        first, second = (_json5(pki_dir / site / f"{r}.json5") for r in ("router", "router2"))
        assert first["listen"]["endpoints"] == [f"tls/0.0.0.0:{port}"]
        assert second["listen"]["endpoints"] == [f"tls/0.0.0.0:{port + 1}"]
        assert first["connect"]["endpoints"] == cloud  # both dial both of the cloud's
        assert second["connect"]["endpoints"] == [*cloud, f"tls/127.0.0.1:{port}"]
        assert [c["metadata"]["wiswarm"]["reload"] for c in (first, second)] == [
            {"turn": 0, "of": 2}, {"turn": 1, "of": 2}]
        follower = _json5(pki_dir / site / "uav1.json5")
        assert follower["connect"]["endpoints"] == [f"tls/127.0.0.1:{port}",
                                                    f"tls/127.0.0.1:{port + 1}"]
        assert follower["connect"]["retry"]["period_init_ms"] == 100
    subjects = _subjects(pki_dir / "s1" / "router.json5")
    # A node is its certificate and its password; a router its certificate alone (the
    # router it dials shows it no user name).
    assert subjects["s1/uav1"]["usernames"] == ["s1/uav1"]
    assert "usernames" not in subjects["s1/router2"] and "usernames" not in subjects["router"]


def test_each_node_has_its_password_and_each_place_a_password_file(pki_dir: Path) -> None:
    passwords = json.loads((pki_dir / "passwords.json").read_text())
    login = _json5(pki_dir / "s1" / "uav1.json5")["transport"]["auth"]["usrpwd"]
    assert login == {"user": "s1/uav1", "password": passwords["s1/uav1"]}
    router = _json5(pki_dir / "s1" / "router2.json5")["transport"]["auth"]["usrpwd"]
    assert router["dictionary_file"] == str(pki_dir / "s1" / "users.txt")
    assert _users(pki_dir / "s1") == ["s1/router", "s1/router2", "s1/leader", "s1/uav1",
                                      "s1/uav2"]
    assert _users(pki_dir) == ["router", "router2", "leader", "ground", "s1/router",
                               "s1/router2", "s2/router", "s2/router2"]
    for path in (pki_dir / "passwords.json", pki_dir / "s1" / "users.txt",
                 pki_dir / "s1" / "uav1.json5", pki_dir / "router.json5"):
        assert stat.S_IMODE(path.stat().st_mode) == 0o600, path


def test_revoke_writes_its_routers_files_without_it_and_nothing_else(
        pki_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = _snapshot(pki_dir)
    assert main(["security", "revoke", "--out", str(pki_dir), "s1/uav1"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1 and "revoked follower s1/uav1 of site s1" in out, out
    [entry] = json.loads((pki_dir / "revoked.json").read_text())
    cert = x509.load_pem_x509_certificate((pki_dir / "s1" / "uav1.pem").read_bytes())
    assert entry["name"] == "s1/uav1" and entry["kind"] == "follower"
    assert entry["site"] == "s1" and entry["serial"] == f"{cert.serial_number:x}"
    assert datetime.datetime.fromisoformat(entry["when"]).tzinfo is not None
    for router in ("router", "router2"):
        assert "s1/uav1" not in _subjects(pki_dir / "s1" / f"{router}.json5")
        assert "s1/uav2" in _subjects(pki_dir / "s1" / f"{router}.json5")
    assert "s1/uav1" not in _users(pki_dir / "s1")
    after = _snapshot(pki_dir)
    changed = sorted(str(p.relative_to(pki_dir)) for p in after if after[p] != before.get(p))
    assert changed == ["revoked.json", "s1/router.json5", "s1/router2.json5", "s1/users.txt"]


def test_revoking_a_site_takes_its_routers_out_of_the_clouds(
        pki_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["security", "revoke", "--out", str(pki_dir), "s2"]) == 0
    assert "revoked site s2 and its 4 identities" in capsys.readouterr().out
    entries = json.loads((pki_dir / "revoked.json").read_text())
    assert [(e["name"], e["kind"]) for e in entries] == [
        ("s2", "site"), ("s2/router", "router"), ("s2/router2", "router"),
        ("s2/leader", "edge leader"), ("s2/uav1", "follower")]
    for router in ("router", "router2"):
        config = _json5(pki_dir / f"{router}.json5")["access_control"]
        assert not [s for s in config["subjects"] if s["id"].startswith("site-s2/")]
        assert "site-s2" not in {p["id"] for p in config["policies"]}
        assert "s1/router" in _subjects(pki_dir / f"{router}.json5")
    assert _users(pki_dir) == ["router", "router2", "leader", "ground", "s1/router",
                               "s1/router2"]
    assert _users(pki_dir / "s2") == []


def test_a_revoked_name_is_never_issued_again_and_stays_out(
        pki_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("s1/uav1", "s2"):
        assert main(["security", "revoke", "--out", str(pki_dir), name]) == 0
    capsys.readouterr()
    for argv, message in ((["add-follower", "--site", "s1", "uav1"],
                           "follower 's1/uav1' was revoked on"),
                          (["add-follower", "--site", "s2", "uav9"], "site 's2' was revoked on"),
                          (["add-site", "s2:uav1"], "site 's2' was revoked on")):
        code = main(["security", argv[0], "--out", str(pki_dir), *argv[1:]])
        said_in_one_line(code, capsys.readouterr().err, message)
    assert main(["security", "add-follower", "--out", str(pki_dir), "--site", "s1",
                 "uav3"]) == 0
    assert main(["security", "add-site", "--out", str(pki_dir), "s3:uav1"]) == 0
    assert "s1/uav1" not in _subjects(pki_dir / "s1" / "router.json5")
    assert "s1/uav3" in _subjects(pki_dir / "s1" / "router.json5")
    assert "s1/uav1" not in _users(pki_dir / "s1")
    cloud = {*_users(pki_dir), *_subjects(pki_dir / "router.json5")}
    assert not {"s2/router", "s2/router2"} & cloud
    assert "s3/router2" in _users(pki_dir)


@pytest.mark.parametrize(("name", "message"), [
    ("uav7", "no 'uav7' here: see wiswarm security list"),
    ("uav1", "no 'uav1' here (in a site, name it SITE/uav1: s1/uav1, s2/uav1)"),
    ("s1/router2", "'s1/router2' is a router of s1, which cannot be revoked alone: revoke "
                   "its site, s1"),
    ("leader", "'leader' is a leader of the top, which cannot be revoked alone"),
    ("router", "'router' is a router of the top"),
])
def test_a_name_that_cannot_be_revoked_is_one_line_and_exit_2(
        pki_dir: Path, capsys: pytest.CaptureFixture[str], name: str, message: str) -> None:
    before = _snapshot(pki_dir)
    code = main(["security", "revoke", "--out", str(pki_dir), name])
    said_in_one_line(code, capsys.readouterr().err, message)
    assert _snapshot(pki_dir) == before


def test_revoking_twice_is_one_line_and_exit_2(
        pki_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("ground", "s2"):
        assert main(["security", "revoke", "--out", str(pki_dir), name]) == 0
    capsys.readouterr()
    for name in ("ground", "s2", "s2/uav1"):  # a site's node, once the site is revoked
        code = main(["security", "revoke", "--out", str(pki_dir), name])
        said_in_one_line(code, capsys.readouterr().err, f"'{name}' was already revoked on")


def test_revoke_without_init_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for command in (["revoke", "--out", str(tmp_path), "f1"], ["list", "--out", str(tmp_path)]):
        code = main(["security", *command])
        said_in_one_line(code, capsys.readouterr().err, "security.json: not found")


def test_list_shows_who_is_issued_and_who_is_revoked(
        pki_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("s1/uav2", "s2"):
        assert main(["security", "revoke", "--out", str(pki_dir), name]) == 0
    capsys.readouterr()
    assert main(["security", "list", "--out", str(pki_dir)]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = {line.split()[0]: line.split() for line in lines[1:-1]}
    assert lines[0].split() == ["name", "role", "site", "expires", "state"]
    expires = f"{datetime.datetime.now(datetime.UTC) + datetime.timedelta(days=365):%Y-%m-%d}"
    assert rows["router2"] == ["router2", "router", "-", expires, "issued"]
    assert rows["ground"] == ["ground", "observer", "-", expires, "issued"]
    assert rows["s1/leader"] == ["s1/leader", "edge", "leader", "s1", expires, "issued"]
    assert rows["s1/uav1"][-1] == "issued"
    assert rows["s1/uav2"][:4] == ["s1/uav2", "follower", "s1", expires]
    assert rows["s1/uav2"][4] == "revoked"
    assert rows["s2/uav1"][4] == "revoked" and rows["s2"][:4] == ["s2", "site", "s2", "-"]
    assert len(rows) == 14 and lines[-1] == "8 issued, 5 revoked"
