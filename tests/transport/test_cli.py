"""``wiswarm router|leader|follower|demo``: bad input is one line and exit 2; the demo
writes its files, and Ctrl-C leaves no process behind."""

from __future__ import annotations

import functools
import io
import os
import select
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from wiswarm_zenoh.cli import main as cli_main
from wiswarm_zenoh.cli import nodes
from wiswarm_zenoh.programs.demo import DemoOptions, run_demo
from wiswarm_zenoh.transport.zenoh_config import SessionSpec, free_tcp_port

from .helpers import WAIT

ENTRY = ("import sys; from wiswarm_zenoh.cli import main as m, nodes; "
         "sys.exit(m.main(registrars=(nodes.register,)))")
CONFIGS = Path(__file__).resolve().parents[2] / "configs"


@pytest.fixture
def wiswarm() -> object:
    return functools.partial(cli_main.main, registrars=(nodes.register,))


@pytest.mark.parametrize(("argv", "message"), [
    (["router", "-e", "nowhere"], "endpoint 'nowhere' must look like tcp/HOST:PORT"),
    (["router", "--cfg", "transport"], "--cfg expects KEY:VALUE, got 'transport'"),
    (["router", "--cfg", "no/such/key:1"], "--cfg no/such/key: unknown key"),
    (["router", "--cfg", "mode:'tree'"], "unknown variant `tree`"),
    (["router", "-c", "/no/such/file.json5"], "config file /no/such/file.json5: no such file"),
    (["leader", "--alpha", "1.5"], "alpha must be in [0, 1], got 1.5"),
    (["leader", "--swarm", "a/b"], "swarm name 'a/b' must not contain /"),
    (["leader", "--control-period", "-1"], "--control-period: must be >= 0, got -1"),
    (["follower", "--id", "x*"], "follower id 'x*' must not contain *"),
    (["follower", "--id", "control"], "follower id 'control' is reserved"),
    (["follower", "--id", "a", "--frame-bytes", "8"], "--frame-bytes must be in [16,"),
    (["follower", "--id", "a", "--fragment-size", "100"], "fragment_size must be >"),
])
def test_bad_flags_are_one_line_and_exit_2(
    wiswarm: object, capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    assert cli_main.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"wiswarm {argv[0]}: error: ")
    assert message in err


@pytest.mark.parametrize("argv", [["leader", "--policy", "best"], ["follower"],
                                  ["swarm-demo", "--followers", "0"], ["leader", "-m", "router"]])
def test_argparse_errors_exit_2(wiswarm: object, capsys: pytest.CaptureFixture[str],
                                argv: list[str]) -> None:
    assert cli_main.main(argv) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_a_follower_flag_given_twice_is_one_line_and_exit_2() -> None:
    """Not the last one served silently: argparse's default for a repeated flag."""
    wiswarm = Path(sys.executable).with_name("wiswarm")
    done = subprocess.run([str(wiswarm), "follower", "--id", "d1", "--ros2-waypoints",
                           "/a/path", "--ros2-waypoints", "/b/path"],
                          capture_output=True, text=True, timeout=WAIT)
    assert done.returncode == 2
    assert done.stderr == ("wiswarm follower: error: --ros2-waypoints given twice (/a/path, "
                           "/b/path): a follower publishes its waypoints on one topic\n")
    assert done.stdout == ""


@pytest.mark.parametrize(("flags", "said"), [
    (["--ros2-topic", "/a", "--ros2-topic", "/a"], "/a given twice: a robot serves a stream "
     "once"),
    (["--source", "robot/a", "--source", "robot/a/**"], "robot/a and robot/a/** are both "
     "member 'd1~robot_a': name one, NAME=robot/a/**"),
    (["--id", "d.1", "--source", "robot/a"], "argument --id: follower id 'd.1' must not "
     "contain .: it joins a site and its follower in a cloud's (<site>.<id>)"),
])
def test_streams_that_cannot_be_told_apart_are_one_line_and_exit_2(
        flags: list[str], said: str) -> None:
    wiswarm = Path(sys.executable).with_name("wiswarm")
    done = subprocess.run([str(wiswarm), "follower", "--id", "d1", *flags],
                          capture_output=True, text=True, timeout=WAIT)
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr == f"wiswarm follower: error: {said}\n"


def test_a_client_whose_router_never_came_says_so_and_fails(
    wiswarm: object, caplog: pytest.LogCaptureFixture
) -> None:
    """Zenoh opens a client only once its router answers: the node waits for it to the
    end of its run, then names where it looked (exit 1, as a peer that reached none)."""
    port = free_tcp_port()
    argv = ["leader", "-m", "client", "-e", f"tcp/127.0.0.1:{port}",
            "--no-multicast-scouting", "--duration", "1"]
    assert cli_main.main(argv) == 1
    said = [r.getMessage() for r in caplog.records if "no router was ever reached" in
            r.getMessage()]
    assert len(said) == 1 and f"tcp/127.0.0.1:{port}" in said[0]


def test_the_demo_shows_the_table_and_writes_its_files(tmp_path: Path) -> None:
    out = io.StringIO()
    run_dir = run_demo(DemoOptions(followers=2, duration=3.0, out=str(tmp_path)), out)
    text = out.getvalue()
    assert "summary" in text and "uav1" in text and "uav2" in text
    stats = (run_dir / "stats.csv").read_text().splitlines()
    assert stats[0].startswith("time_s,follower,aoi_s,mean_aoi_s,p95_aoi_s,p_hat")
    assert {line.split(",")[1] for line in stats[1:]} == {"uav1", "uav2"}
    assert (run_dir / "aoi.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len((run_dir / "deliveries.csv").read_text().splitlines()) > 50


def _children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def _wait_gone(pid: int) -> bool:
    try:
        fd = os.pidfd_open(pid)
    except ProcessLookupError:
        return True
    try:
        return bool(select.select([fd], [], [], WAIT)[0])
    finally:
        os.close(fd)


def test_ctrl_c_stops_the_demo_and_every_child(tmp_path: Path) -> None:
    demo = subprocess.Popen(
        [sys.executable, "-c", ENTRY, "swarm-demo", "--followers", "2", "--duration", "60",
         "--out", str(tmp_path)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert demo.stdout is not None
        for line in demo.stdout:  # the table is drawn once everyone is up
            if line.startswith("WiSwarm demo:"):
                break
        children = _children(demo.pid)
        assert len(children) >= 4  # router, leader, 2 followers
        demo.send_signal(signal.SIGINT)
        rest = demo.communicate(timeout=WAIT)[0]
    finally:
        demo.kill()
    assert demo.returncode == 130
    assert "interrupted: every process stopped" in rest
    assert all(_wait_gone(pid) for pid in children)


def test_sigterm_stops_a_node_as_ctrl_c_does() -> None:
    """A service manager stops a node with SIGTERM: it ends as after Ctrl-C (its summary
    printed, exit 0), not killed by the signal (-15) with its summary lost. (With its
    router: one that never reached any exits 1, saying so.)"""
    port = free_tcp_port()
    router = SessionSpec.loopback("router", port).open()
    leader = subprocess.Popen(
        [sys.executable, "-c", ENTRY, "leader", "--swarm", "term", "-e",
         f"tcp/127.0.0.1:{port}", "--no-multicast-scouting"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert leader.stdout is not None
        for line in leader.stdout:  # its table is drawn once it runs
            if "polls/s, up" in line:
                break
        leader.send_signal(signal.SIGTERM)
        rest = leader.communicate(timeout=WAIT)[0]
    finally:
        leader.kill()
        router.close()
    assert leader.returncode == 0, rest
    assert "summary" in rest


@pytest.mark.parametrize("spec, delay", [
    (SessionSpec.loopback("router", 7447), "0"),  # nobody to scout: it opens at once
    (SessionSpec("router", listen=("tcp/127.0.0.1:7447",)), "null"),  # multicast scouting
    (SessionSpec.loopback("router", 7447, connect_ports=[7448]), "null"),  # a router to reach
    (SessionSpec.loopback("peer", connect_ports=[7447]), "null"),
    (SessionSpec(config_file=str(CONFIGS / "router.json5"), multicast_scouting=False,
                 cfg=("scouting/delay:200",)), "200"),  # as the config says
])
def test_a_router_with_nobody_to_scout_skips_zenohs_scouting_delay(spec: SessionSpec,
                                                                   delay: str) -> None:
    assert spec.config().get_json("scouting/delay") == delay


@pytest.mark.parametrize("mode", ["router", "peer", "client"])
def test_the_shipped_zenoh_configs_load(mode: str) -> None:
    config = SessionSpec(config_file=str(CONFIGS / f"{mode}.json5")).config()
    assert config.get_json("mode") == f'"{mode}"'


def test_a_watching_tool_with_no_router_at_e_says_so_in_one_line(tmp_path: Path) -> None:
    """``record`` given -e is a client: no router there, one line naming it, exit 2."""
    port = free_tcp_port()
    wiswarm = Path(sys.executable).with_name("wiswarm")
    done = subprocess.run([str(wiswarm), "record", "-o", str(tmp_path / "run.mcap"), "-e",
                           f"tcp/127.0.0.1:{port}", "--no-multicast-scouting", "--duration",
                           "1"], capture_output=True, text=True, timeout=WAIT)
    assert done.returncode == 2
    assert done.stderr == (f"wiswarm record: error: cannot open the Zenoh session: no router "
                           f"answered at tcp/127.0.0.1:{port} (a client opens only once its "
                           "router answers): is one listening there (wiswarm router -l "
                           "...)?\n")
