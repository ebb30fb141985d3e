"""``wiswarm security`` and the nodes it configures, as a user runs them."""

from __future__ import annotations

import datetime
import subprocess
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from wiswarm_zenoh.cli.main import main
from wiswarm_zenoh.options import UsageError
from wiswarm_zenoh.security import pki
from wiswarm_zenoh.testbed.faults import Output
from wiswarm_zenoh.transport import SessionSpec
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

from .helpers import WAIT, wiswarm


@pytest.fixture
def swarm(tmp_path: Path) -> tuple[Path, int]:
    port = free_tcp_port()
    directory = tmp_path / "swarm"
    assert main(["security", "init", "--out", str(directory), "--followers", "f1,f2",
                 "--port", str(port), "--listen", f"tls/127.0.0.1:{port}"]) == 0
    return directory, port


def test_a_secured_swarm_runs_from_the_command_line(swarm: tuple[Path, int]) -> None:
    directory, port = swarm
    # The default log level: the router shows what access control refused, and only that.
    router = subprocess.Popen(wiswarm("router", "-c", str(directory / "router.json5")),
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    follower = None
    try:
        log = Output("router", router)
        log.wait_for("wiswarm router: listening")
        follower = subprocess.Popen(
            wiswarm("follower", "--id", "f1", "-c", str(directory / "f1.json5"),
                     "--duration", "8"), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            text=True)
        leader = subprocess.run(
            wiswarm("leader", "-c", str(directory / "leader.json5"), "--duration", "3"),
            capture_output=True, text=True, timeout=60)
        assert leader.returncode == 0, leader.stderr
        summary = leader.stdout.split("\nsummary\n")[1].splitlines()
        row = next(line.split() for line in summary if line.split()[:1] == ["f1"])
        mean_ms, polls_per_s = float(row[2]), float(row[6])
        assert mean_ms > 0 and polls_per_s > 0  # f1 was polled, and delivered
        with SessionSpec(config_file=str(directory / "f2.json5")).open() as rogue:
            rogue.put("wiswarm/swarm/control", b"rogue")
            rogue.declare_queryable("wiswarm/swarm/f1/update", lambda query: None)
            log.wait_for("access control refused f2: Put (ingress) on wiswarm/swarm/control")
            log.wait_for("access control refused f2: Declare Queryable (ingress) on "
                         "wiswarm/swarm/f1/update")
        assert not [line for line in log.lines if "authorized" in line]  # no trace flood
        # A node without a certificate is refused at the TLS handshake, logged at warn
        # (the default level).
        with pytest.raises(UsageError, match="cannot open the Zenoh session"):
            SessionSpec("client", connect=(f"tls/127.0.0.1:{port}",), multicast_scouting=False,
                        cfg=(f'transport/link/tls/root_ca_certificate:"{directory}/ca.pem"',)
                        ).open()
        log.wait_for("WARN", "peer sent no certificates")
    finally:
        router.terminate()
        router.wait(WAIT)
        if follower is not None:
            follower.kill()
            follower.wait(WAIT)


def _forge(directory: Path, name: str, days_from_now: tuple[int, int],
           authority: pki.Authority | None = None) -> None:
    """Replace ``name``'s certificate (and key) with one valid between the given days."""
    authority = authority or pki.load_authority(directory)
    key = ec.generate_private_key(ec.SECP256R1())
    now = datetime.datetime.now(datetime.UTC)
    start, end = (now + datetime.timedelta(days=d) for d in days_from_now)
    cert = (x509.CertificateBuilder()
            .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)]))
            .issuer_name(authority.cert.subject).public_key(key.public_key())
            .serial_number(x509.random_serial_number()).not_valid_before(start)
            .not_valid_after(end).sign(authority.key, hashes.SHA256()))
    pki.write_pair(directory, name, cert, key)


def _spoil(directory: Path, case: str) -> None:
    """Make one thing wrong in a fresh swarm directory."""
    if case == "missing certificate":
        (directory / "f1.pem").unlink()
    elif case == "not a key":
        (directory / "f1-key.pem").write_text("not a key\n")
    elif case == "another node's key":
        (directory / "f1-key.pem").write_bytes((directory / "f2-key.pem").read_bytes())
    elif case == "expired":
        _forge(directory, "leader", (-10, -1))
    elif case == "not yet valid":
        _forge(directory, "leader", (1, 10))
    elif case == "another CA":
        _forge(directory, "f1", (-1, 10), pki.new_authority("other", 1))
    elif case == "missing CA":
        (directory / "ca.pem").unlink()


@pytest.mark.parametrize(("case", "argv", "message"), [
    ("none", ["follower", "--id", "f9", "-c", "{d}/f1.json5"],
     "certificate {d}/f1.pem (in {d}/f1.json5) is f1's, not f9's"),
    ("none", ["follower", "--id", "f9", "-c", "{d}/f9.json5"],
     "config file {d}/f9.json5: no such file"),
    ("missing certificate", ["follower", "--id", "f1", "-c", "{d}/f1.json5"],
     "certificate {d}/f1.pem: cannot read it (No such file or directory)"),
    ("not a key", ["follower", "--id", "f1", "-c", "{d}/f1.json5"],
     "private key {d}/f1-key.pem: not an unencrypted PEM private key"),
    ("another node's key", ["follower", "--id", "f1", "-c", "{d}/f1.json5"],
     "private key {d}/f1-key.pem: does not match certificate {d}/f1.pem"),
    ("expired", ["leader", "-c", "{d}/leader.json5"], "certificate {d}/leader.pem: expired on"),
    ("not yet valid", ["leader", "-c", "{d}/leader.json5"],
     "certificate {d}/leader.pem: not valid before"),
    ("another CA", ["follower", "--id", "f1", "-c", "{d}/f1.json5"],
     "certificate {d}/f1.pem: not signed by the CA {d}/ca.pem"),
    ("missing CA", ["router", "-c", "{d}/router.json5"],
     "CA certificate {d}/ca.pem: cannot read it"),
])
def test_bad_certificates_are_one_line_and_exit_2(
        swarm: tuple[Path, int], capsys: pytest.CaptureFixture[str], case: str,
        argv: list[str], message: str) -> None:
    directory = swarm[0].resolve()
    _spoil(directory, case)
    capsys.readouterr()
    assert main([arg.format(d=directory) for arg in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message.format(d=directory) in err, err


@pytest.mark.parametrize("argv", [["follower", "--id", "f1", "-c", "{d}/f1.json5"],
                                  ["leader", "-c", "{d}/leader.json5"]])
def test_a_node_started_for_another_swarm_than_its_rules_cover_is_one_line(
        swarm: tuple[Path, int], capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    """Its rules cover its own swarm's keys only: it would run silently dead."""
    directory = swarm[0].resolve()
    capsys.readouterr()
    assert main([*(arg.format(d=directory) for arg in argv), "--swarm", "other"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pass --swarm s" in err, err
