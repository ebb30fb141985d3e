"""The command line's contract, for every flag of every subcommand of ``wiswarm``: a bad
value ends with exit code 2 and one line on stderr naming the problem, no traceback,
before any session, process or file is made.

The flags are found by walking the real parser, so a new one is tried as soon as it is
added; one without a kind (a plain ``type=float``, say: not an ``ArgType``) fails it.
A bad value that is a legitimate one for some flag is listed below with the reason, and
checked to parse; it is not run.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from wiswarm_zenoh.cli import main as cli
from wiswarm_zenoh.options import ArgType

BAD = ("nan", "inf", "-inf", "", "x" * 300, "/nonexistent/dir/file", "tcp/999.1.1.1:1",
       "-1", "0")
# More bad values by kind; {tmp} is the test's directory, {file} a regular file in it.
MORE_BAD = {
    "float": ("1e400", "NaN", "1,5"),
    "int": ("1.5", "2x"),
    "file": ("{tmp}", "{file}/sub"),
    "dir": ("{file}", "{file}/sub"),
    "endpoint": ("tcp/127.0.0.1:99999", "foo/127.0.0.1:7447", "tcp/127.0.0.1",
                 "tcp/no-such-host.invalid:7447", "tcp/1.2.3:7447"),
    "host:port": ("127.0.0.1:0", "999.1.1.1:80", "no-such-host.invalid:80", "[::1"),
    "int list": ("2,x", "2,0", "2,"),
    "float list": ("1,nan", "1,-1"),
    "range": ("1:nan", "2:1", "0.5"),
    "member=weight": ("uav1=-1", "uav1=nan", "uav1=1e400", "uav1=", "=2", "uav1", "a b=1",
                      "leader=1", "u/1=2"),
}

A_NAME = "a key chunk: any word without / * $ ? # or spaces, within the wire's length"
A_RELATIVE_PATH = "a path relative to the working directory"
# Values of BAD accepted by every flag of a kind, and why.
ALLOWED_BY_KIND: dict[str, dict[str, str]] = {
    "name": dict.fromkeys(("nan", "inf", "-inf", "-1", "0"), A_NAME),
    "name list": dict.fromkeys(("nan", "inf", "-inf", "-1", "0"), A_NAME),
    "file": dict.fromkeys(("nan", "inf", "-inf", "-1", "0"), A_RELATIVE_PATH),
    "dir": {**dict.fromkeys(("nan", "inf", "-inf", "-1", "0", "tcp/999.1.1.1:1"),
                            A_RELATIVE_PATH + " that mkdir -p makes"),
            **({"/nonexistent/dir/file": "mkdir -p makes it: / is writable (root)"}
               if os.access("/", os.W_OK) else {})},
    "host list": dict.fromkeys(("nan", "inf"), "a host name of another machine (a "
                               "certificate's), not resolved here"),
    "run id": dict.fromkeys(("nan", "inf", "0"), "a channel name: letters, digits, - and _"),
    "key expression": dict.fromkeys(("nan", "inf", "-inf", "-1", "0", "x" * 300,
                                     "tcp/999.1.1.1:1"), "a Zenoh key expression"),
    "ROS topic": {"/nonexistent/dir/file": "a ROS topic of three tokens"},
}
# Values accepted by one flag (``command --flag``, or ``--flag`` of every command).
ALLOWED_BY_FLAG: dict[str, dict[str, str]] = {
    "--seed": {"0": "seed 0 is the default"},
    "leader --alpha": {"0": "an EMA factor in [0, 1]"},
    "leader --control-period": {"0": "0 puts control information with every poll"},
    "--ros-domain": {"0": "ROS's default domain"},
    "--ros-namespace": {"/nonexistent/dir/file": "a ROS namespace of three tokens"},
    "foxglove --port": {"0": "any free port"},
    "experiment testbed --warmup": {"0": "no warm-up: the window opens at once"},
}
# Values for required flags while another flag is tried, by kind.
VALID = {"name": "uav1", "int": "3", "dir": "{tmp}/out", "name list": "f1,f2", "site": "s9:f1",
         "rate": "20mbit", "file": "{tmp}/out.mcap"}
# What would start something: reaching one of these means a bad value got through.
STARTERS = (
    "wiswarm_zenoh.cli.nodes.run_router", "wiswarm_zenoh.cli.nodes.run_demo",
    "wiswarm_zenoh.cli.leader_command.run_receiver", "wiswarm_zenoh.cli.leader_command.run_leader",
    "wiswarm_zenoh.cli.follower_command.run_follower",
    "wiswarm_zenoh.cli.follower_command.run_baseline_followers",
    "wiswarm_zenoh.cli.sim.run_slotted", "wiswarm_zenoh.cli.sim.run_wifi",
    "wiswarm_zenoh.cli.sim.run_link", "wiswarm_zenoh.cli.sim.run_sweep",
    "wiswarm_zenoh.options.testbed.check_available", "wiswarm_zenoh.cli.experiment.run_study",
    "wiswarm_zenoh.cli.security.init", "wiswarm_zenoh.cli.security.add_follower",
    "wiswarm_zenoh.cli.security.add_site", "wiswarm_zenoh.cli.security_revoke.revoke",
    "wiswarm_zenoh.cli.edge_cloud.run_edge_cloud", "wiswarm_zenoh.cli.dashboard.serve",
    "wiswarm_zenoh.cli.recording.run_recording",
    "wiswarm_apps.tracking.demo.run",
)


class Started(Exception):
    """A bad value reached something that starts work."""


Command = tuple[tuple[str, ...], list[argparse.Action]]


def _commands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()) -> Iterator[Command]:
    """Every (sub)command with its own arguments, nested ones too."""
    own = [a for a in parser._actions if not isinstance(a, argparse._SubParsersAction)]
    yield path, own
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _commands(sub, (*path, name))


def _name(action: argparse.Action) -> str:
    return max(action.option_strings, key=len) if action.option_strings else action.dest


def _kind(action: argparse.Action) -> str | None:
    if action.nargs == 0:
        return "switch"
    if action.choices is not None:
        return "choice"
    return action.type.kind if isinstance(action.type, ArgType) else None


CASES = [(path, action.dest) for path, actions in _commands(cli.build_parser())
         for action in actions if path]


def _argv(path: tuple[str, ...], actions: list[argparse.Action], tried: argparse.Action,
          value: str, tmp: Path) -> list[str]:
    """The command with ``value`` for ``tried`` and valid values for the required others."""
    options, positionals = [], []
    for action in actions:
        given = value if action is tried else None
        if given is None and action.required:
            given = VALID[str(_kind(action))].format(tmp=tmp)
        if given is None:
            continue
        if action.option_strings:
            options.append(f"{_name(action)}={given}")
        else:
            positionals.append(given)
    return [*path, *options, *(["--", *positionals] if positionals else [])]


def _allowed(path: tuple[str, ...], action: argparse.Action, value: str) -> str | None:
    flag = _name(action)
    for table in (ALLOWED_BY_FLAG.get(f"{' '.join(path)} {flag}", {}),
                  ALLOWED_BY_FLAG.get(flag, {}), ALLOWED_BY_KIND.get(str(_kind(action)), {})):
        if value in table:
            return table[value]
    return None


def _names_it(line: str, action: argparse.Action, value: str) -> bool:
    """The line says which flag, or which value, is wrong (words too short to tell
    anything, like --n's "n" or the value "0", do not count)."""
    def squeeze(text: str) -> str:
        return text.lower().replace("-", "").replace("_", "")
    words = [squeeze(action.dest), squeeze(value[:30])]
    return (any(flag in line for flag in action.option_strings)
            or any(len(word) > 2 and word in squeeze(line) for word in words))


@pytest.fixture
def guarded(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """Nothing may start; relative paths land in the test's own directory."""
    def started(*_args: object, **_kwargs: object) -> None:
        raise Started
    for target in STARTERS:
        monkeypatch.setattr(target, started)
    monkeypatch.chdir(tmp_path)


@pytest.mark.usefixtures("guarded")
@pytest.mark.parametrize(("path", "dest"), CASES,
                         ids=[f"{' '.join(p)}:{d}" for p, d in CASES])
def test_every_bad_value_is_one_line_and_exit_2(
        path: tuple[str, ...], dest: str, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    actions = dict(_commands(cli.build_parser()))[path]
    action = next(a for a in actions if a.dest == dest)
    kind = _kind(action)
    assert kind is not None, (f"{' '.join(path)} {_name(action)}: give it a type of "
                              "wiswarm_zenoh.options, or choices")
    if kind == "switch":
        return  # takes no value
    (tmp_path / "file").write_text("")
    for required in (a for a in actions if a.required and a is not action):
        assert str(_kind(required)) in VALID, f"no valid value for {_name(required)}"
    failures = []
    for template in (*BAD, *MORE_BAD.get(kind, ())):
        value = template.format(tmp=tmp_path, file=tmp_path / "file")
        argv = _argv(path, actions, action, value, tmp_path)
        if _allowed(path, action, value) is not None:
            try:
                cli.build_parser().parse_args(argv)
            except SystemExit:
                failures.append(f"{argv}: listed as allowed, refused: {capsys.readouterr().err}")
            continue
        try:
            code = cli.main(argv)
        except Started:
            failures.append(f"{argv}: accepted, and it started")
            continue
        err = capsys.readouterr().err
        lines = err.splitlines()
        if (code != 2 or len(lines) != 1 or "Traceback" in err or "error: " not in lines[0]
                or not _names_it(lines[0], action, value)):
            failures.append(f"{argv}: exit {code}, stderr {err!r}")
    assert not failures, "\n".join(failures)


def test_the_walk_finds_every_subcommand_and_every_flag_allowed_here() -> None:
    commands = list(_commands(cli.build_parser()))
    assert {"router", "leader", "follower", "swarm-demo", "sim slotted", "sim wifi",
            "sim link", "testbed up", "testbed down", "testbed set", "experiment sweep",
            "experiment testbed", "experiment tracking", "security init",
            "security add-follower", "security add-site",
            "demo"} <= {" ".join(path) for path, _ in commands}
    flags = {name for path, actions in commands for action in actions
             for name in (_name(action), f"{' '.join(path)} {_name(action)}")}
    assert set(ALLOWED_BY_FLAG) <= flags  # no stale exception
