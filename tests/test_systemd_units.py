"""The systemd units in configs/systemd: systemd accepts them, each runs a command line
``wiswarm`` takes (with the example environment file, and with its secured variant the
configs ``wiswarm security init`` writes), and a node stopped as systemd stops it exits
with a code its unit counts as success."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from wiswarm_zenoh.cli.main import build_parser, main
from wiswarm_zenoh.testbed.faults import Process
from wiswarm_zenoh.transport.zenoh_config import free_tcp_port

UNITS = Path(__file__).resolve().parent.parent / "configs" / "systemd"
INSTALLED = "/usr/local/bin/wiswarm"  # where the units say wiswarm is
UNIT_COMMANDS = {"wiswarm-router.service": "router", "wiswarm-leader.service": "leader",
                 "wiswarm-follower@.service": "follower"}
INSTANCE = "uav1"
SECURED = "#WISWARM_"  # the example file's secured variant, commented out
# The config each unit's secured command names, as `wiswarm security init` calls it.
SECURED_CONFIGS = {"router": "router.json5", "leader": "leader.json5",
                   "follower": f"{INSTANCE}.json5"}
WAIT = 60.0


def _settings(unit: Path) -> dict[str, list[str]]:
    """Each key of the unit's [Service] section and its values, in order."""
    values: dict[str, list[str]] = {}
    for line in unit.read_text(encoding="utf-8").splitlines():
        if "=" in line and not line.startswith("#"):
            key, _, value = line.partition("=")
            values.setdefault(key.strip(), []).append(value.strip())
    return values


def _environment(unit: Path, secured: bool = False) -> dict[str, str]:
    """The unit's Environment= defaults, then the example file's lines over them (and
    with ``secured``, its commented-out secured variant over those)."""
    env = dict(pair.split("=", 1) for setting in _settings(unit).get("Environment", [])
               for pair in setting.split())
    lines = (UNITS / "wiswarm.env").read_text(encoding="utf-8").splitlines()
    given = [line for line in lines if line and not line.startswith("#")]
    if secured:
        given += [line[1:] for line in lines if line.startswith(SECURED)]
    for line in given:
        key, _, value = line.partition("=")
        env[key] = value
    return env


def command(unit: Path, secured: bool = False) -> list[str]:
    """The unit's ExecStart as systemd runs it: ``${VAR}`` one word, ``$VAR`` split at
    spaces, ``%i`` the instance."""
    env = _environment(unit, secured)
    words: list[str] = []
    for word in _settings(unit)["ExecStart"][0].replace("%i", INSTANCE).split():
        if (whole := re.fullmatch(r"\$\{(\w+)\}", word)) is not None:
            words.append(env.get(whole.group(1), ""))
        elif (split := re.fullmatch(r"\$(\w+)", word)) is not None:
            words += env.get(split.group(1), "").split()
        else:
            words.append(word)
    return words


@pytest.mark.parametrize("name", sorted(UNIT_COMMANDS))
def test_each_unit_runs_a_command_wiswarm_takes(name: str) -> None:
    argv = command(UNITS / name)
    assert argv[0] == INSTALLED
    args = build_parser().parse_args(argv[1:])  # a flag wiswarm lacks: SystemExit
    assert args.command == UNIT_COMMANDS[name]
    if args.command != "router":
        assert args.swarm == "s1"  # the example file's, over the unit's default


@pytest.mark.parametrize("name", sorted(UNIT_COMMANDS))
def test_each_unit_runs_as_its_own_user_not_root(name: str) -> None:
    settings = _settings(UNITS / name)
    assert (settings["User"], settings["Group"]) == (["wiswarm"], ["wiswarm"])


@pytest.fixture(scope="module")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """What `wiswarm security init` writes for the example's swarm and follower."""
    directory = tmp_path_factory.mktemp("pki")
    assert main(["security", "init", "--swarm", "s1", "--followers", INSTANCE,
                 "--out", str(directory)]) == 0
    return directory


@pytest.mark.parametrize("name", sorted(UNIT_COMMANDS))
def test_the_secured_variant_runs_the_configs_security_init_writes(name: str,
                                                                   pki: Path) -> None:
    argv = [word.replace("/etc/wiswarm", str(pki))
            for word in command(UNITS / name, secured=True)]
    args = build_parser().parse_args(argv[1:])  # -c of a file init did not write: SystemExit
    assert args.command == UNIT_COMMANDS[name]
    assert args.config == str(pki / SECURED_CONFIGS[args.command])
    assert not args.connect and not args.listen  # where the router is: the config says


def test_systemd_accepts_the_units(tmp_path: Path) -> None:
    analyze = shutil.which("systemd-analyze")
    if analyze is None:
        pytest.skip("systemd-analyze is not installed")
    wiswarm = Path(sys.executable).with_name("wiswarm")
    paths = []
    for name in UNIT_COMMANDS:
        text = (UNITS / name).read_text(encoding="utf-8").replace(INSTALLED, str(wiswarm))
        (tmp_path / name).write_text(text, encoding="utf-8")
        instance = name.replace("@.", f"@{INSTANCE}.")
        if instance != name:
            (tmp_path / instance).symlink_to(tmp_path / name)
        paths.append(str(tmp_path / instance))
    done = subprocess.run([analyze, "verify", "--man=no", *paths], capture_output=True,
                          text=True, timeout=WAIT)
    assert done.returncode == 0 and not done.stdout + done.stderr, done.stdout + done.stderr


def test_a_follower_stopped_as_systemd_does_exits_as_its_unit_expects() -> None:
    """SIGTERM once it runs: a clean stop, with the example's own flags (its ROS 2 topic
    nobody publishes here: it waits for a first sample)."""
    unit = UNITS / "wiswarm-follower@.service"
    success = {0, *(int(code) for code in _settings(unit)["SuccessExitStatus"][0].split())}
    port = free_tcp_port()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    router = Process("router", ["router", "-l", f"tcp/127.0.0.1:{port}",
                                "--no-multicast-scouting"], env)
    try:
        router.wait_for("listening")
        argv = [word if word != "tcp/localhost:7447" else f"tcp/127.0.0.1:{port}"
                for word in command(unit)[1:]]
        follower = Process("follower", argv, env)
        try:
            follower.wait_for("(Ctrl-C to stop)")
            follower.signal(signal.SIGTERM)
            assert follower.popen.wait(WAIT) in success, follower.lines[-5:]
        finally:
            follower.stop()
    finally:
        router.stop()
