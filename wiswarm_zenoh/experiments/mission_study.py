"""Every system through the mission on every medium, after the fixed rates are tuned.

A fixed rate is tuned to a phase's conditions (who flies, their links, their weights)
by static runs of that phase alone (``tune_seconds`` each), the rate chosen by
``search`` (the fine search of ``rate_search``) on their weighted mean AoI. (b1) takes
the first phase's rate, (b2) the rate of the phase with the most robots, (b*) each
phase's own. Rates tuned before in the same output directory (``tuned.json``) are
reused: the search is the long part. So are runs flown before there (a JSON beside each
run's CSV) of the same mission: they are reported with the new ones, so a mission can be
flown system by system, or go on after a stop.

With a weight change in the mission and WiSwarm among the systems, the phase where a
weight first moves is also run statically under WiSwarm twice, with the weights before
and after the change: what the change alone does to each robot's age, the rest equal.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from wiswarm_zenoh.experiments.mission import (
    SYSTEMS,
    MissionConfig,
    MissionRun,
    media,
    run_file,
    run_mission,
)
from wiswarm_zenoh.experiments.mission_metrics import PhaseFigures, phase_figures
from wiswarm_zenoh.experiments.mission_scenario import Mission, Phase

log = logging.getLogger(__name__)

Search = Callable[[Callable[[float], float], float], float]  # (cost of a rate, start) -> best
Progress = Callable[[str], None]


@dataclass
class Tuning:
    """One phase's tuning on one medium: each rate tried and its weighted mean AoI."""

    medium: str
    phase: str
    conditions: str
    tried: list[tuple[float, float]] = field(default_factory=list)
    best: float = 0.0


@dataclass
class WeightCheck:
    """WiSwarm in one phase's conditions, with the weights before and after a change."""

    medium: str
    phase: str
    before: PhaseFigures
    after: PhaseFigures
    raised: tuple[int, ...]  # robots whose weight rose


@dataclass
class MissionResults:
    """Every run, every tuning, the weight checks."""

    runs: list[MissionRun] = field(default_factory=list)
    tunings: list[Tuning] = field(default_factory=list)
    weight_checks: list[WeightCheck] = field(default_factory=list)

    def run(self, medium: str, system: str) -> MissionRun | None:
        return next((r for r in self.runs if (r.medium, r.system) == (medium, system)), None)


def tuning_key(medium: str, phase: Phase) -> str:
    return json.dumps([medium, *phase.conditions()])


def static(phase: Phase, seconds: float) -> Mission:
    """A mission of ``phase``'s conditions alone."""
    return Mission(f"static {phase.name}", (replace(phase, start=0.0, seconds=seconds),))


def run_study(config: MissionConfig, workdir: Path, search: Search,
              progress: Progress | None = None) -> MissionResults:
    """Tune, then run every system through the mission, medium by medium."""
    results = MissionResults()
    cache = workdir / "tuned.json"
    tuned: dict[str, float] = json.loads(cache.read_text()) if cache.exists() else {}
    mission = config.mission
    say = progress or (lambda _: None)
    for name in config.media:
        with media(config, name) as medium_for:
            def once(phase: Phase, system: str, seconds: float, rate: float | None,
                     tag: str, name: str = name) -> PhaseFigures:
                with medium_for() as medium:
                    run = run_mission(medium, name, static(phase, seconds), system, [rate],
                                      workdir, config.tune_warmup, tag=tag)
                return phase_figures(run)[0]

            def flown(system: str, tag: str, mission: Mission, name: str = name
                      ) -> MissionRun | None:
                """A run of an earlier invocation with the same output directory."""
                run = MissionRun.saved(run_file(workdir, name, tag), mission)
                if run is not None:
                    say(f"{name}: {tag}: as flown before ({run_file(workdir, name, tag)})")
                return run

            def tune(phase: Phase, name: str = name) -> float:
                key = tuning_key(name, phase)
                if key in tuned:
                    return tuned[key]
                tuning = Tuning(name, phase.name, key)

                def cost(rate: float) -> float:
                    aoi = once(phase, "fixed-first", config.tune_seconds, rate,
                               "tune").weighted_aoi
                    tuning.tried.append((rate, aoi))
                    say(f"{name}: tuning for {phase.name}: {rate:.3g} Hz -> "
                        f"{aoi * 1e3:.0f} ms")
                    return aoi

                tuning.best = search(cost, config.share_fps(name, len(phase.robots)))
                results.tunings.append(tuning)
                tuned[key] = tuning.best
                cache.write_text(json.dumps(tuned, indent=1))
                return tuning.best

            for system in SYSTEMS:
                run = flown(system, system, mission)
                if run is None and system in config.systems:
                    rates = rates_for(system, mission, tune)

                    def entered(phase: str, system: str = system, name: str = name) -> None:
                        say(f"{name}: {system}: {phase}")

                    with medium_for() as medium:
                        run = run_mission(medium, name, mission, system, rates, workdir,
                                          config.warmup, entered)
                    say(f"{name}: {system} done")
                if run is not None:
                    results.runs.append(run)
            changed = first_weight_change(mission)
            if changed is not None and "wiswarm" in {r.system for r in results.runs}:
                def weighed(phase: Phase, tag: str) -> PhaseFigures:
                    saved = flown("wiswarm", tag, static(phase, config.tune_seconds))
                    return phase_figures(saved)[0] if saved is not None else \
                        once(phase, "wiswarm", config.tune_seconds, None, tag)

                before, after = changed
                results.weight_checks.append(WeightCheck(
                    name, after.name, weighed(before, "weights-before"),
                    weighed(after, "weights-after"),
                    tuple(r for r in after.robots if after.weight_of(r) > before.weight_of(r))))
    return results


def rates_for(system: str, mission: Mission, tune: Callable[[Phase], float]
           ) -> list[float | None]:
    phases = mission.phases
    if system == "fixed-first":
        return [tune(phases[0])] * len(phases)
    if system == "fixed-largest":
        return [tune(mission.largest())] * len(phases)
    if system == "oracle":
        return [tune(phase) for phase in phases]
    return [None] * len(phases)


def first_weight_change(mission: Mission) -> tuple[Phase, Phase] | None:
    """The first phase where a weight moves, as (its conditions with the weights before,
    as they are)."""
    for before, after in zip(mission.phases, mission.phases[1:], strict=False):
        if any(after.weight_of(r) != before.weight_of(r) for r in after.robots):
            return replace(after, weight=before.weight), after
    return None
