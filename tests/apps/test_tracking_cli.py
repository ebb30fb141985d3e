"""`wiswarm demo` flags: bad values are one clear UsageError; a short run writes its files."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import pytest

from wiswarm_apps.tracking.cli import add_demo_arguments
from wiswarm_apps.tracking.demo import DemoOptions
from wiswarm_apps.tracking.demo_runs import LOOK_AFTER, options_from, run_demo
from wiswarm_apps.tracking.report import channel_entry
from wiswarm_zenoh.options import OneLineParser, UsageError
from wiswarm_zenoh.testbed import WifiSpec


def parse(*argv: str) -> argparse.Namespace:
    parser = OneLineParser(prog="wiswarm demo")
    add_demo_arguments(parser)
    return parser.parse_args(argv)


def test_defaults_are_the_paper_setup() -> None:
    options = options_from(parse())
    assert (options.uavs, options.duration_s, options.frame_px, options.rate) == (4, 30, 224, 100)
    assert options_from(parse("--system", "push")).rate == 50  # the paper's fixed rate
    assert options_from(parse(), "push").rate == 50  # the comparison's second run


def test_the_default_channel_is_20_mbit_in_user_space() -> None:
    options = options_from(parse())
    assert options.channel is not None and options.channel_kind == "user"
    assert (options.channel.rate_bps, options.channel.queue_s) == (20_000_000, 0.2)
    assert options.dashboard_port is not None and not options.namespaces
    assert options_from(parse("--channel", "none")).channel is None
    tbf = options_from(parse("--channel", "tbf", "--channel-rate", "5mbit"))
    assert tbf.namespaces and tbf.channel is not None and tbf.channel.rate_bps == 5_000_000
    assert tbf.dashboard_port is None  # it would listen inside a namespace


def test_channel_wifi_makes_each_uav_a_station_of_the_medium() -> None:
    wifi = options_from(parse("--channel", "wifi"))
    assert isinstance(wifi.channel, WifiSpec) and wifi.channel_kind == "wifi"
    assert wifi.namespaces and wifi.dashboard_port is None  # root; inside a namespace
    assert channel_entry(wifi) == {"kind": "wifi", **dataclasses.asdict(WifiSpec())}
    with pytest.raises(ValueError, match="dashboard cannot run with --channel wifi"):
        DemoOptions(channel=WifiSpec(), channel_kind="wifi")
    with pytest.raises(ValueError, match="the wifi channel kind goes with a WifiSpec"):
        DemoOptions(channel=WifiSpec(), channel_kind="tbf", dashboard_port=None)


@pytest.mark.parametrize(("argv", "words"), [
    (("--uavs", "51"), "uavs must be in [1, 50]"),
    (("--duration", "0.5"), "duration must be in"),
    (("--rate", "5000"), "rate must be in (0, 1000]"),
    (("--warmup", "0.1"), "warm-up must be in"),
])
def test_bad_values_are_usage_errors(argv: tuple[str, ...], words: str) -> None:
    with pytest.raises(UsageError, match=words.replace("[", r"\[").replace("(", r"\(")):
        options_from(parse(*argv))


@pytest.mark.parametrize(("argv", "words"), [
    (("--no-dashboard",), "not with --no-dashboard"),
    (("--channel", "tbf"), "there is none with --channel tbf"),
    (("--channel", "wifi"), "there is none with --channel wifi"),
])
def test_keep_dashboard_needs_one(argv: tuple[str, ...], words: str) -> None:
    assert options_from(parse("--keep-dashboard")).dashboard_port is not None
    with pytest.raises(UsageError, match=f"--keep-dashboard needs the dashboard: {words}"):
        options_from(parse("--keep-dashboard", *argv))


@pytest.mark.parametrize(("argv", "words"), [
    (("--system", "udp"), "invalid choice"),
    (("--uavs", "0"), "--uavs: must be >= 1"),
    (("--duration", "nan"), "--duration: expected a finite number"),
    (("--rate", "-5"), "--rate: must be > 0"),
    (("--channel", "20mbit"), "'20mbit' is not one of user, tbf, wifi, none (a rate goes "
                              "in "
                              "--channel-rate)"),
    (("--channel-rate", "fast"), "rate 'fast' is not a rate"),
])
def test_unparseable_values_exit_with_code_2(capsys: pytest.CaptureFixture[str],
                                             argv: tuple[str, ...], words: str) -> None:
    with pytest.raises(SystemExit) as exit_info:
        parse(*argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]


def test_out_must_be_a_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "file"
    target.write_text("")
    with pytest.raises(SystemExit):
        parse("--out", str(target))
    assert "exists and is not a directory" in capsys.readouterr().err


def test_a_short_run_prints_a_summary_and_writes_the_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    code = run_demo(parse("--system", "wiswarm", "--channel", "none", "--uavs", "1",
                          "--duration", "1", "--warmup", "1", "--no-live", "--no-gif",
                          "--frame-size", "160", "--out", str(out)))
    assert code == 0
    printed = capsys.readouterr().out
    assert "uav0: AoI mean" in printed and "car in view" in printed
    assert printed.rstrip().endswith(LOOK_AFTER)  # the dashboard went: how to keep it
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frame_px"] == 160 and set(summary["per_uav"]) == {"uav0"}
    assert summary["systems"]["wiswarm"]["channel"] is None  # loopback
    assert summary["systems"]["wiswarm"]["mean_aoi_s"] == summary["average"]["mean_aoi_s"]
    assert not (out / "world.gif").exists() and (out / "trajectories.png").exists()
    assert (out / "run.mcap").stat().st_size > 0  # read channel by channel in tests/recording
