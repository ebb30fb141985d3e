"""Experiment studies published as they fill in, for the dashboard (``--live``).

``wiswarm experiment sweep|testbed --live`` runs its study one N at a time through the
study's own runner (the same runs, seeds and scheduling within an N as without
``--live``), and after each N puts every point so far, as the study's report computes
them, on ``wiswarm/experiments/<run>/points`` (JSON, ``application/json``)::

    {"study": "sweep", "run": "sweep-20261123-161500", "baselines": ["udp", "tcp"],
     "fixed_rate": 50.0, "done": false,
     "points": [{"label": "wiswarm", "n": 2, "rate": null,
                 "mean": {"mean_aoi_s": 0.02, ...}, "std": {...}}, ...]}

Labels are the report's: ``wiswarm``, ``<baseline>@<rate>`` for each rate run and
``<baseline>-opt`` at the best one. Each message holds every point so far, so a
dashboard opened midway has the whole run at the next N. ``<run>`` is the output
directory's name. Publishing needs a Zenoh session, which an experiment otherwise does
not open (the sweep is pure simulation): hence a flag, not always.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import re
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import zenoh

from wiswarm_zenoh.dashboard.feed import points_key
from wiswarm_zenoh.experiments.sweep import Point, SweepConfig, summarise
from wiswarm_zenoh.experiments.testbed_study import StudyConfig, StudyResults
from wiswarm_zenoh.experiments.testbed_study_report import summarise as summarise_study
from wiswarm_zenoh.options import CONNECT_ENDPOINT
from wiswarm_zenoh.sim.metrics import WifiResult
from wiswarm_zenoh.transport.entities import undeclare
from wiswarm_zenoh.transport.zenoh_config import LOCAL_ROUTER, SessionSpec

Progress = Callable[[int, int], None]
_NOT_IN_A_CHUNK = re.compile(r"[/*$?#\s]")


def add_live_arguments(parser: argparse.ArgumentParser) -> None:
    """``--live`` and ``--live-connect``, as every study takes them."""
    parser.add_argument("--live", action="store_true",
                        help="publish the points as each N is done, on wiswarm/experiments/"
                        "<run>/points (run: the output directory's name), for wiswarm "
                        "dashboard")
    parser.add_argument("--live-connect", metavar="ENDPOINT", action="append", default=[],
                        type=CONNECT_ENDPOINT,
                        help="where --live publishes: a Zenoh endpoint (repeatable; default "
                        f"{LOCAL_ROUTER}, a wiswarm router there); implies --live")


def run_name(out: Path) -> str:
    """The run's key chunk: the output directory's name, its key-unsafe characters as _."""
    return _NOT_IN_A_CHUNK.sub("_", out.resolve().name) or "run"


@contextlib.contextmanager
def open_live(args: argparse.Namespace, out: Path, study: str, baselines: Sequence[str],
              fixed_rate: float) -> Iterator[LivePoints | None]:
    """The publisher of ``--live`` on a session of its own (a peer of a router on this
    machine, or of ``--live-connect``), or None without it."""
    if not (args.live or args.live_connect):
        yield None
        return
    spec = SessionSpec(mode="peer", connect=tuple(args.live_connect) or (LOCAL_ROUTER,))
    with spec.open() as session:
        live = LivePoints(session, run_name(out), study, baselines, fixed_rate)
        try:
            yield live
        finally:
            live.close()


class LivePoints:
    """Puts a study's points so far on ``wiswarm/experiments/<run>/points``."""

    def __init__(self, session: zenoh.Session, run: str, study: str,
                 baselines: Sequence[str], fixed_rate: float) -> None:
        self._session = session  # held: a session nobody references is closed
        self._head = {"study": study, "run": run, "baselines": list(baselines),
                      "fixed_rate": fixed_rate}
        self._publisher = session.declare_publisher(
            points_key(run), encoding=zenoh.Encoding.APPLICATION_JSON)
        self.publish([], done=False)  # the run shows at once, empty

    def publish(self, points: Sequence[Point], done: bool) -> None:
        self._publisher.put(json.dumps({
            **self._head, "done": done,
            "points": [dataclasses.asdict(point) for point in points]}))

    def close(self) -> None:
        undeclare(self._publisher)


def _shifted(progress: Progress, offset: int, at_least: int) -> Progress:
    """The progress of one N's runs as the whole study's: after the ``offset`` runs
    before, out of at least ``at_least``."""
    def shifted(done: int, total: int) -> None:
        progress(offset + done, max(at_least, offset + total))
    return shifted


def sweep_by_n(config: SweepConfig, run: Callable[[SweepConfig, Progress], list[WifiResult]],
               progress: Progress, live: LivePoints) -> list[WifiResult]:
    """``run`` (the sweep's runner) on each N in turn; every point so far after each."""
    results: list[WifiResult] = []
    total = len(config.plan())
    for i, n in enumerate(config.ns):
        results += run(dataclasses.replace(config, ns=(n,)),
                       _shifted(progress, len(results), total))
        so_far = dataclasses.replace(config, ns=config.ns[:i + 1])
        live.publish(summarise(so_far, results), done=i + 1 == len(config.ns))
    return results


def study_by_n(config: StudyConfig, run: Callable[[StudyConfig, Progress], StudyResults],
               progress: Progress, live: LivePoints) -> StudyResults:
    """``run`` (the testbed study's runner) on each N in turn; every point so far after
    each; an interrupted N ends it (what was measured is kept)."""
    merged = StudyResults()
    for i, n in enumerate(config.ns):
        part = run(dataclasses.replace(config, ns=(n,)),
                   _shifted(progress, len(merged.outcomes), config.estimated_runs))
        merged.outcomes += part.outcomes
        merged.best.update(part.best)
        merged.interrupted = part.interrupted
        so_far = dataclasses.replace(config, ns=config.ns[:i + 1])
        last = part.interrupted or i + 1 == len(config.ns)
        live.publish(summarise_study(so_far, merged), done=last)
        if last:
            break
    return merged
