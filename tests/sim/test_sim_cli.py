"""``wiswarm sim`` and ``wiswarm experiment sweep`` through the real entry point."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from wiswarm_zenoh.cli import main as cli


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict[str, object]:
    assert cli.main(argv) == 0
    out: dict[str, object] = json.loads(capsys.readouterr().out)
    return out


def test_sim_slotted_prints_the_fields_of_the_issue(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["sim", "slotted", "--n", "5", "--policy", "whittle", "--seed", "3",
            "--weights", "1:2", "--reliability", "0.6:0.9", "--slots", "3000", "--json"]
    out = _json(capsys, argv)
    assert out["n"] == 5
    assert out["policy"] == "whittle"
    w, p = out["w"], out["p"]
    assert isinstance(w, list) and len(w) == 5 and all(1 <= x <= 2 for x in w)
    assert isinstance(p, list) and all(0.6 <= x <= 0.9 for x in p)
    assert out["ratio"] == pytest.approx(out["ewsaoi"] / out["lower_bound"])  # type: ignore[operator]
    assert _json(capsys, argv) == out


def test_sim_wifi_prints_per_follower_and_mean_metrics(capsys: pytest.CaptureFixture[str]) -> None:
    out = _json(capsys, ["sim", "wifi", "--n", "3", "--system", "tcp", "--rate", "10",
                         "--duration", "2", "--seed", "1", "--json"])
    assert out["system"] == "tcp" and out["n"] == 3 and out["rate"] == 10.0
    followers = out["followers"]
    assert isinstance(followers, list) and len(followers) == 3
    assert {"mean_aoi_s", "p95_aoi_s", "peak_aoi_s", "throughput_fps", "deliveries"} <= set(
        followers[0]
    )
    mean = out["mean"]
    assert isinstance(mean, dict)
    assert mean["mean_aoi_s"] == pytest.approx(sum(f["mean_aoi_s"] for f in followers) / 3)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["sim", "slotted", "--n", "0"], "--n: must be >= 1"),
        (["sim", "slotted", "--n", "4", "--reliability", "0:0.5"], "reliability"),
        (["sim", "slotted", "--n", "4", "--reliability", "0.5:1.5"], "reliability"),
        (["sim", "slotted", "--n", "4", "--policy", "psychic"], "policy"),
        (["sim", "wifi", "--n", "4", "--system", "udp", "--rate", "-3"], "rate"),
        (["sim", "wifi", "--n", "4", "--system", "carrier-pigeon"], "system"),
        (["sim", "wifi", "--n", "4", "--frame-bytes", "20000000"], "frame_bytes"),
        (["sim", "wifi", "--n", "4", "--rate", "10"], "--rate"),
        (["experiment", "sweep", "--batches", "0"], "batches"),
    ],
)
def test_impossible_parameters_end_with_one_line_and_exit_2(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert message in err
    assert err.count("\n") == 1


def test_unparseable_ranges_are_argparse_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["sim", "slotted", "--n", "3", "--weights", "heavy"]) == 2
    assert "LO:HI" in capsys.readouterr().err


def test_sweep_writes_csv_figures_and_the_gains_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "sweep"
    argv = ["experiment", "sweep", "--ns", "2,8", "--rates", "5,50", "--batches", "2",
            "--duration", "1.5", "--jobs", "1", "--out", str(out), "--search", "grid"]
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert "20/20 runs" in captured.err  # 2 N x 2 batches x (WiSwarm + 2 baselines x 2 rates)
    with (out / "runs.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 20
    assert {r["system"] for r in rows} == {"wiswarm", "udp", "tcp"}
    with (out / "summary.csv").open() as fh:
        labels = {r["label"] for r in csv.DictReader(fh)}
    assert {"wiswarm", "udp@50", "tcp@5", "udp-opt", "tcp-opt"} <= labels
    for name in ("mean_aoi.png", "p95_aoi.png", "throughput.png", "aoi_vs_rate_n8.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = (out / "gains.md").read_text()
    assert "| 8 | udp@50 | 50 |" in table
    assert "| 8 | tcp-opt |" in table
    assert "| 8 | tcp | 9.86 | 5: " in table  # the grid's search: its rates, from the share
    assert table in captured.out


def test_the_sweep_searches_each_best_rate_finely_from_the_share(tmp_path: Path) -> None:
    """By default each baseline's best rate at each N is the fine search's: off the grid,
    its rates listed in gains.md from the air's share, in runs.csv beside the grid's."""
    out = tmp_path / "sweep"
    argv = ["experiment", "sweep", "--ns", "8", "--rates", "5", "--batches", "1",
            "--duration", "20", "--jobs", "2", "--out", str(out)]
    assert cli.main(argv) == 0
    with (out / "runs.csv").open() as fh:
        rates = {(r["system"], float(r["rate"] or 0)) for r in csv.DictReader(fh)}
    with (out / "summary.csv").open() as fh:
        best = {r["label"]: float(r["rate"]) for r in csv.DictReader(fh)
                if r["label"].endswith("-opt")}
    assert best.keys() == {"udp-opt", "tcp-opt"}
    for label, rate in best.items():
        assert rate not in (5.0, 50.0) and (label.removesuffix("-opt"), rate) in rates
    searched = {system for system, rate in rates if rate not in (0.0, 5.0, 50.0)}
    assert searched == {"udp", "tcp"}
    table = (out / "gains.md").read_text()
    assert "by the fine search" in table
    line = next(line for line in table.splitlines() if line.startswith("| 8 | udp | 9.86 | "))
    assert "9.86: " in line  # the share, tried
