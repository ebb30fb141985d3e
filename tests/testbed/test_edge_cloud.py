"""The edge-cloud experiment on real namespaces, routers, relays and leaders: every
setup delivers every pair, ages add up across the WAN hop, the files are written, and
nothing is left behind, however the process that built the topology ends."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest

from wiswarm_zenoh.cli import main as cli
from wiswarm_zenoh.experiments.edge_cloud_topology import RECORDS, cleanup_leftovers
from wiswarm_zenoh.testbed.channel_records import list_channels
from wiswarm_zenoh.testbed.netns import NETNS_DIR

pytestmark = pytest.mark.testbed
DELAY = 0.02
SETUPS = ("direct", "hierarchy x2", "hierarchy, K auto", "edge alone")


def _mine() -> set[str]:
    """Namespaces and records of this process (their names carry its pid)."""
    pid = f"{os.getpid():x}-"
    names = {p.name for p in NETNS_DIR.glob("wsw-*")} | {p.stem for p in RECORDS.glob("*")}
    return {name for name in names if pid in name}


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as src:
        return list(csv.DictReader(src))


def test_a_short_run_delivers_every_pair_with_ages_added_across_the_wan(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "ec"
    code = cli.main(["experiment", "edge-cloud", "--sites", "2", "--followers", "2",
                     "--wan", "50mbit", "--delay", "20ms", "--duration", "2", "--warmup",
                     "1", "--in-flight", "2,auto", "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0, printed
    assert not _mine(), "the topology was not torn down"
    for name in ("pairs.csv", "summary.csv", "aoi.png", "report.md"):
        assert (out / name).stat().st_size > 0, name
    assert "Floor = " in printed and "| hierarchy x2 | 2 |" in printed
    summary = _rows(out / "summary.csv")
    assert [row["setup"] for row in summary] == list(SETUPS)
    assert all(float(row["least_age_s"]) > DELAY for row in summary[:3])  # over the WAN

    delivered: dict[str, set[str]] = defaultdict(set)
    for row in _rows(out / "pairs.csv"):
        if int(row["deliveries"]) > 0:
            delivered[row["setup"]].add(row["pair"])
    pairs = {f"s{s}.uav{i}" for s in (1, 2) for i in (0, 1)}
    assert all(delivered[setup] == pairs for setup in SETUPS), delivered

    records = out / "records"
    for tag in ("d", "h2"):  # every update reaching the cloud crossed the WAN once
        rows = _rows(records / f"{tag}-cloud.csv")
        assert {row["follower"] for row in rows} == pairs
        assert min(float(r["delivered_at"]) - float(r["generated_at"]) for r in rows) > DELAY
    # Through the hierarchy, each update reached its edge first, and the cloud at least
    # the one-way delay later: the cloud's age is the edge's plus the hop.
    at_edge = {(r["follower"], r["generated_at"]): float(r["delivered_at"])
               for site in (1, 2) for r in _rows(records / f"h2-edge-s{site}.csv")}
    for row in _rows(records / "h2-cloud.csv"):
        edge_time = at_edge[(row["follower"], row["generated_at"])]
        assert float(row["delivered_at"]) - edge_time > DELAY, row


def test_a_topology_whose_owner_was_killed_is_removed_by_the_next_cleanup() -> None:
    script = ("from wiswarm_zenoh.experiments.edge_cloud_topology import EdgeCloud, WanSpec\n"
              "from wiswarm_zenoh.testbed.spec import ChannelSpec\n"
              "import sys, threading\n"
              "net = EdgeCloud(1, ChannelSpec(), WanSpec()).build()\n"
              "site = net.sites[0].channel\n"
              "print(net.run_id, net.cloud_ns, site.run_id, site.leader_ns, flush=True)\n"
              "threading.Event().wait()\n")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        run_id, cloud_ns, channel, site_ns = proc.stdout.readline().split()
        assert (NETNS_DIR / cloud_ns).exists() and (RECORDS / f"{run_id}.json").exists()
        orphan = f"wsw-ec{os.getpid():x}-orphan-C"  # a cloud namespace without a record
        subprocess.run(["ip", "netns", "add", orphan], check=True)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert {run_id, orphan[4:-2]} <= set(cleanup_leftovers())
    assert not (NETNS_DIR / orphan).exists()
    assert not (NETNS_DIR / cloud_ns).exists() and not (NETNS_DIR / site_ns).exists()
    assert channel not in list_channels()
    assert not (RECORDS / f"{run_id}.json").exists()
