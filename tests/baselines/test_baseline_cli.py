"""``wiswarm follower|leader --system push|udp|tcp``: flags a system does not take, and
frames too big for a datagram, are one line and exit 2; ``--help`` explains; a receiver
and a follower run from the command line, and the receiver records every delivery."""

from __future__ import annotations

import csv
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from wiswarm_zenoh.cli import main as cli_main
from wiswarm_zenoh.cli import nodes
from wiswarm_zenoh.programs.delivery_csv import DeliveryRecord
from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port


@pytest.fixture(autouse=True)
def nodes_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """The middleware's subcommands only (the tracking app's are not needed here). Their
    module is imported at collection, above: LiveTable's default stream is the sys.stdout
    of that moment, which must outlive each test's own capture."""
    monkeypatch.setattr(cli_main, "every_command", lambda: (nodes.register,))


@pytest.fixture
def router_port() -> Iterator[int]:
    port = free_tcp_port()
    with SessionSpec.loopback("router", port).open():
        yield port


def _zenoh(port: int) -> list[str]:
    return ["-e", f"tcp/127.0.0.1:{port}", "-l", "tcp/127.0.0.1:0", "--no-multicast-scouting"]


@pytest.mark.parametrize(("argv", "message"), [
    (["follower", "--id", "a", "--system", "udp"], "--system udp needs --to HOST:PORT"),
    (["follower", "--id", "a", "--system", "tcp"], "--system tcp needs --to HOST:PORT"),
    (["follower", "--id", "a", "--system", "tcp", "--to", "127.0.0.1:9", "--congestion",
      "drop"], "--congestion is for --system push, not tcp"),
    (["follower", "--id", "a", "--congestion", "drop"],
     "--congestion is for --system push, not wiswarm"),
    (["follower", "--id", "a", "--system", "push", "--to", "127.0.0.1:9"],
     "--to is for --system udp/tcp, not push"),
    (["follower", "--id", "a", "--system", "udp", "--to", "127.0.0.1:9", "--queue", "fifo"],
     "--queue is for --system wiswarm, not udp"),
    (["follower", "--id", "a", "--system", "udp", "--to", "127.0.0.1:9", "--frame-bytes",
      "65500"], "frame_bytes 65500 does not fit one UDP datagram (at most 65484"),
    (["follower", "--id", "a", "--system", "udp", "--to", "nowhere"],
     "argument --to: 'nowhere' must look like HOST:PORT"),
    (["follower", "--id", "a", "--system", "push", "--frame-bytes", "8"],
     "frame_bytes must be in [16, 16777216], got 8"),
    (["follower", "--id", "a", "--system", "push", "--newest-only", "--congestion", "drop"],
     "--newest-only sends each frame once the previous put completed: it needs "
     "--congestion block"),
    (["follower", "--id", "a", "--system", "push", "--newest-only", "--capacity", "2"],
     "--capacity sizes the FIFO: --newest-only keeps one frame"),
    (["follower", "--id", "a", "--system", "udp", "--to", "127.0.0.1:9", "--newest-only"],
     "--newest-only is for --system push/tcp, not udp"),
    (["follower", "--id", "a", "--system", "tcp", "--to", "127.0.0.1:9", "--send-buffer",
      "4096"], "--send-buffer is for --newest-only"),
    (["follower", "--id", "a", "--system", "push", "--newest-only", "--send-buffer", "4096"],
     "--send-buffer is for --system tcp, not push"),
    (["follower", "--id", "a", "--system", "push", "--ros2-topic", "/d/camera"],
     "--ros2-topic with --system push needs --newest-only"),
    (["follower", "--id", "a", "--system", "tcp", "--to", "127.0.0.1:9", "--newest-only",
      "--ros2-topic", "/d/camera"], "--ros2-topic is for --system wiswarm/push, not tcp"),
    (["leader", "--system", "tcp", "--bind", "nowhere"], "must look like HOST:PORT"),
    (["leader", "--system", "push", "--bind", "127.0.0.1:7450"],
     "--bind is for --system udp/tcp, not push"),
    (["leader", "--system", "udp", "--policy", "round-robin"],
     "--policy is for --system wiswarm, not udp"),
    (["leader", "--bind", "127.0.0.1:7450"], "--bind is for --system udp/tcp, not wiswarm"),
])
def test_bad_flags_are_one_line_and_exit_2(
        capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    assert cli_main.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"wiswarm {argv[0]}: error: ")
    assert message in err


def test_an_address_in_use_is_one_line_and_exit_2(
        router_port: int, capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        bind = f"127.0.0.1:{taken.getsockname()[1]}"
        argv = ["leader", "--system", "tcp", "--bind", bind, "--duration", "1",
                *_zenoh(router_port)]
        assert cli_main.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"cannot listen on {bind}: Address already in use" in err


@pytest.mark.parametrize(("command", "words"), [
    ("follower", ["--system", "push", "udp", "tcp", "FIFO", "--congestion", "block", "drop",
                  "--to", "--capacity", "one datagram", "--newest-only", "keep only the "
                  "newest frame", "the moment the previous send completed", "--send-buffer",
                  "SO_SNDBUF", "/wiswarm/<swarm>/<id>TOPIC"]),
    ("leader", ["--system", "--bind", "7450", "wiswarm/<swarm>/leader/stats", "--record"]),
])
def test_help_explains_the_systems(capsys: pytest.CaptureFixture[str], command: str,
                                   words: list[str]) -> None:
    assert cli_main.main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for word in words:
        assert word in text


@pytest.mark.parametrize(("flags", "announced"), [
    (["--rate", "50"], "into a FIFO of 64, tcp (to "),
    (["--newest-only", "--send-buffer", "8192"],
     "frames at 100 Hz, newest only, send buffer 8192 B, tcp (to "),
])
def test_a_receiver_and_a_follower_from_the_command_line(
        router_port: int, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        flags: list[str], announced: str) -> None:
    """Both in this process (a session each), as two terminals would run them; a
    newest-only follower's receiver is the FIFO one's (the same frames on the socket)."""
    bind, record = f"127.0.0.1:{free_tcp_port()}", tmp_path / "record.csv"
    leader = ["leader", "--swarm", "s1", "--system", "tcp", "--bind", bind, "--record",
              str(record), "--duration", "3", *_zenoh(router_port)]
    follower = ["follower", "--swarm", "s1", "--id", "f1", "--system", "tcp", "--to", bind,
                *flags, "--duration", "1.5", *_zenoh(router_port)]
    codes: list[int] = []
    receiver = threading.Thread(target=lambda: codes.append(cli_main.main(leader)))
    receiver.start()
    assert cli_main.main(follower) == 0
    receiver.join()
    assert codes == [0]
    out = capsys.readouterr().out
    assert "tcp receiver on " + bind in out and announced + bind in out
    with record.open(newline="") as src:
        rows = list(csv.reader(src))
    assert tuple(rows[0]) == DeliveryRecord.FIELDS
    assert len(rows) > 20 and {row[0] for row in rows[1:]} == {"f1"}
