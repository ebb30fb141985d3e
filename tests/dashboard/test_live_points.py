"""``--live``: a study run one N at a time gives the same results as in one go, and its
points so far go out after each N, as the dashboard reads them."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import zenoh

from tests.transport.helpers import Samples, Sessions, wait_until_known
from wiswarm_zenoh.dashboard.feed import points_key
from wiswarm_zenoh.dashboard.live_points import LivePoints, run_name, study_by_n, sweep_by_n
from wiswarm_zenoh.dashboard.records import parse_points
from wiswarm_zenoh.experiments.sweep import SweepConfig, run_sweep
from wiswarm_zenoh.experiments.testbed_study import StudyConfig, StudyResults
from wiswarm_zenoh.sim.metrics import FollowerMetrics, WifiResult
from wiswarm_zenoh.testbed.run import RunOutcome

from .conftest import loopback

RUN = "run-1"


def published(samples: Samples) -> list[dict[str, Any]]:
    with samples.cond:
        return [parse_points(json.loads(s.payload.to_bytes()), RUN) for s in samples.samples]


def live(sessions: Sessions, port: int, study: str, baselines: tuple[str, ...]
         ) -> tuple[LivePoints, Samples]:
    """A publisher of run RUN, and a subscriber that has seen its first (empty) put."""
    reader = Samples(sessions.open(loopback("peer", port)), points_key("*"))
    publisher_session: zenoh.Session = sessions.open(loopback("peer", port))
    wait_until_known(publisher_session, points_key(RUN))
    points = LivePoints(publisher_session, RUN, study, baselines, 50.0)
    reader.wait("the run announced", lambda s: len(s.samples) == 1)
    return points, reader


def test_a_sweep_by_n_is_the_sweep_and_publishes_its_points_after_each_n(
        sessions: Sessions, port: int) -> None:
    config = SweepConfig(ns=(2, 3), rates=(10.0,), fixed_rate=50.0, batches=1, duration=1.0,
                         search="grid")  # the grid's runs alone: the same N by N
    points, reader = live(sessions, port, "sweep", ("udp", "tcp"))
    progress: list[tuple[int, int]] = []
    results = sweep_by_n(config, lambda part, p: run_sweep(part, 1, p),
                         lambda done, total: progress.append((done, total)), points)
    points.close()
    assert results == run_sweep(config, 1, lambda done, total: None)
    assert progress[0] == (0, 10) and progress[-1] == (10, 10)
    assert [done for done, _ in progress] == sorted(done for done, _ in progress)
    reader.wait("a put after each N", lambda s: len(s.samples) == 3)
    first, after_2, after_3 = published(reader)
    assert (first["points"], first["done"], first["study"]) == ([], False, "sweep")
    assert {p["n"] for p in after_2["points"]} == {2} and not after_2["done"]
    assert {p["n"] for p in after_3["points"]} == {2, 3} and after_3["done"]
    labels = {p["label"] for p in after_3["points"]}
    assert {"wiswarm", "udp@50", "tcp@10", "udp-opt", "tcp-opt"} <= labels


def outcome(system: str, n: int, rate: float | None, aoi: float) -> RunOutcome:
    follower = FollowerMetrics("uav0", aoi, aoi, aoi, 10, 10.0, 1.0)
    return RunOutcome(WifiResult(system, n, rate, 1000, 1.0, 0, [follower]))


def test_a_testbed_study_by_n_merges_its_parts_and_stops_where_one_was_cut(
        sessions: Sessions, port: int) -> None:
    config = StudyConfig(ns=(2, 4, 6), baselines=("udp",), rates=(10.0, 50.0), duration=1.0,
                         search="grid")
    points, reader = live(sessions, port, "testbed", ("udp",))
    parts: list[tuple[int, ...]] = []

    def run(part: StudyConfig, progress: Any) -> StudyResults:
        n = part.ns[0]
        parts.append(part.ns)
        progress(0, part.estimated_runs)
        progress(3, part.estimated_runs)
        results = StudyResults(outcomes=[outcome("wiswarm", n, None, 0.01),
                                         outcome("udp", n, 50.0, 0.5),
                                         outcome("udp", n, 10.0, 0.2)],
                               best={("udp", n, 0): 10.0})
        return dataclasses.replace(results, interrupted=n == 4)  # Ctrl-C during N = 4

    progress: list[tuple[int, int]] = []
    results = study_by_n(config, run, lambda done, total: progress.append((done, total)),
                         points)
    points.close()
    assert parts == [(2,), (4,)]
    assert results.interrupted
    assert len(results.outcomes) == 6 and results.best == {("udp", 2, 0): 10.0,
                                                           ("udp", 4, 0): 10.0}
    assert progress == [(0, 15), (3, 15), (3, 15), (6, 15)]
    reader.wait("a put after each N", lambda s: len(s.samples) == 3)
    last = published(reader)[-1]
    assert last["done"]
    best = {(p["label"], p["n"]): p["rate"] for p in last["points"]}
    assert best[("udp-opt", 4)] == 10.0 and ("wiswarm", 6) not in best


def test_the_run_is_named_after_its_output_directory(tmp_path: Path) -> None:
    assert run_name(tmp_path / "sweep-20261123-161500") == "sweep-20261123-161500"
    assert run_name(tmp_path / "my run*1") == "my_run_1"
