"""``wiswarm testbed up|status|set|down`` through its parser, as ``wiswarm`` runs it."""

from __future__ import annotations

import os
import shutil
import sys
from collections.abc import Sequence

import pytest

import wiswarm_zenoh.cli.testbed as cli
from wiswarm_zenoh import options
from wiswarm_zenoh.options import OneLineParser, UsageError
from wiswarm_zenoh.testbed import (
    Channel,
    TestbedUnavailable,
    list_channels,
    remove_channel,
    unavailable_reason,
)

needs_root = pytest.mark.testbed


def _main(argv: Sequence[str]) -> int:
    """What ``wiswarm`` does with a command (cli/main.py), with only this module's."""
    parser = OneLineParser(prog="wiswarm")
    subparsers = parser.add_subparsers(dest="command", parser_class=OneLineParser)
    cli.register(subparsers)
    try:
        args = parser.parse_args(argv)
        code: int = args.func(args)
    except SystemExit as exc:
        return int(exc.code or 0)
    except UsageError as exc:
        print(f"wiswarm {args.command}: error: {exc}", file=sys.stderr)
        return 2
    return code


def _one_line_error(capsys: pytest.CaptureFixture[str], argv: Sequence[str]) -> str:
    assert _main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("argv", [
    ["testbed", "up", "--rate", "0"],
    ["testbed", "up", "--rate", "fast"],
    ["testbed", "up", "--down-rate", "1tbit"],
    ["testbed", "up", "--queue", "0"],
    ["testbed", "up", "--burst", "lots"],
    ["testbed", "up", "--burst", "100"],
    ["testbed", "up", "--name", "no/slash"],
    ["testbed", "set", "--rate", "-5mbit"],
    ["testbed", "set"],
    ["testbed", "sideways"],
    ["testbed", "up", "--medium", "radio"],
    ["testbed", "up", "--medium", "wifi", "--stations", "0"],
    ["testbed", "up", "--medium", "wifi", "--stations", "many"],
    ["testbed", "up", "--medium", "wifi", "--standard", "80211b"],
    ["testbed", "up", "--medium", "wifi", "--hard-limit", "0"],
])
def test_bad_input_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str],
                                          argv: list[str]) -> None:
    _one_line_error(capsys, argv)


def test_without_root_it_says_so_and_points_to_the_simulator(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    def not_root() -> None:
        raise TestbedUnavailable(unavailable_reason(1000, shutil.which) or "")

    monkeypatch.setattr(options.testbed, "check_available", not_root)
    for action in (["up"], ["down"], ["status"], ["set", "--rate", "5mbit"]):
        err = _one_line_error(capsys, ["testbed", *action])
        assert "needs root" in err and "wiswarm sim link" in err


def test_help_explains_every_flag(capsys: pytest.CaptureFixture[str]) -> None:
    assert _main(["testbed", "up", "--help"]) == 0
    out = capsys.readouterr().out
    for flag in ("--rate", "--down-rate", "--queue", "--burst", "--name"):
        assert flag in out
    assert _main(["testbed", "set", "--help"]) == 0
    assert "RUN_ID" in capsys.readouterr().out


def test_sizes_are_in_tcs_spelling() -> None:
    assert [options.parse_size(text) for text in ("32kb", "32k", "1mb", "40000", "1500b")] == [
        32768, 32768, 1024**2, 40000, 1500]
    with pytest.raises(ValueError, match="size"):
        options.parse_size("32kbit")


@needs_root
def test_up_status_set_down(capsys: pytest.CaptureFixture[str]) -> None:
    run_id = f"cli{os.getpid():x}"
    try:
        assert _main(["testbed", "up", "--rate", "10mbit", "--down-rate", "4mbit",
                      "--queue", "100ms", "--name", run_id]) == 0
        out = capsys.readouterr().out
        channel = Channel.attach(run_id)
        assert channel.persistent
        assert f"run id: {run_id}" in out
        assert f"leader side: router + leader in {channel.leader_ns} at " in out
        assert f"ip netns exec {channel.follower_ns} wiswarm follower" in out
        assert "transport/shared_memory/enabled:false" in out

        assert _main(["testbed", "status"]) == 0
        out = capsys.readouterr().out
        assert f"testbed channel {run_id}" in out
        assert "10mbit: sent" in out and "4mbit: sent" in out and "dropped" in out

        assert _main(["testbed", "set", "--rate", "5mbit", run_id]) == 0
        assert "uplink 10mbit -> 5mbit, downlink 4mbit -> 5mbit" in capsys.readouterr().out
        assert Channel.attach(run_id).spec.down_bps == 5_000_000

        assert _main(["testbed", "down", run_id]) == 0
        assert f"removed testbed channel {run_id}" in capsys.readouterr().out
        assert run_id not in list_channels()
        err = _one_line_error(capsys, ["testbed", "down", run_id])
        assert "no testbed channel" in err
    finally:
        if run_id in list_channels():
            remove_channel(run_id)


@needs_root
def test_up_refuses_a_name_in_use(capsys: pytest.CaptureFixture[str]) -> None:
    with Channel(name=f"dup{os.getpid():x}") as channel:
        err = _one_line_error(capsys, ["testbed", "up", "--name", channel.run_id])
        assert "exists already" in err


@needs_root
def test_set_and_down_without_an_id(capsys: pytest.CaptureFixture[str],
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """Other channels and WiFi media may exist on this machine (other runs): the CLI is
    shown only ours, so that `down` without an id, which removes every one, removes only
    ours."""
    channel = Channel(name=f"all{os.getpid():x}").build(persistent=True)
    try:
        shown = [channel.run_id]
        monkeypatch.setattr(cli, "list_channels", lambda: list(shown))
        monkeypatch.setattr(cli, "list_media", list)  # no WiFi media: others' are not ours
        assert _main(["testbed", "set", "--rate", "2mbit"]) == 0
        assert Channel.attach(channel.run_id).spec.rate_bps == 2_000_000
        shown.append("other")
        assert "give the run id" in _one_line_error(capsys, ["testbed", "set", "--rate", "1mbit"])
        shown.remove("other")
        capsys.readouterr()
        assert _main(["testbed", "down"]) == 0
        assert capsys.readouterr().out == f"removed testbed channel {channel.run_id}\n"
        assert channel.run_id not in list_channels()
        shown.clear()
        assert "no testbed channel" in _one_line_error(capsys, ["testbed", "set", "--rate",
                                                                "1mbit"])
    finally:
        if channel.run_id in list_channels():
            remove_channel(channel.run_id)
