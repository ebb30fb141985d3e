"""What a mission run measured, phase by phase and over the whole mission: each robot's
mean and p95 AoI at the ground's subscriber, the weighted mean AoI, the channel's bytes,
and the AoI against time for the figure.

A robot's age starts at its take-off (nothing of it has reached the ground yet) and is
measured while it flies; a phase's figures are over the robots that fly in it, weighted
by the phase's weights. Over the whole mission, a robot's phases count by their length
(robot-seconds), so a phase of eight robots weighs twice one of four.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

from wiswarm_zenoh.experiments.mission import MissionRun, Stint
from wiswarm_zenoh.experiments.mission_scenario import Phase
from wiswarm_zenoh.experiments.ros2_air_nodes import IMAGE_BYTES, robot_name
from wiswarm_zenoh.sim.metrics import FollowerMetrics
from wiswarm_zenoh.testbed.run import window_metrics

SAMPLE_PERIOD = 0.5  # seconds between the figure's points


@dataclass(frozen=True)
class RobotFigures:
    """One robot over one phase (or the whole mission): its ground age and weight."""

    robot: int
    weight: float
    seconds: float
    metrics: FollowerMetrics


@dataclass(frozen=True)
class PhaseFigures:
    """One phase (or the whole mission) of one run."""

    name: str
    robots: tuple[RobotFigures, ...]
    up_bytes: int
    down_bytes: int

    def _mean(self, value: str, weighted: bool) -> float:
        total = sum(r.seconds * (r.weight if weighted else 1.0) for r in self.robots)
        if total <= 0:
            return math.nan
        return sum(r.seconds * (r.weight if weighted else 1.0) * float(getattr(r.metrics, value))
                   for r in self.robots) / total

    @property
    def mean_aoi(self) -> float:
        return self._mean("mean_aoi_s", False)

    @property
    def p95_aoi(self) -> float:
        """The robots' p95 ages, averaged (over robot-seconds)."""
        return self._mean("p95_aoi_s", False)

    @property
    def weighted_aoi(self) -> float:
        return self._mean("mean_aoi_s", True)

    def robot(self, index: int) -> RobotFigures | None:
        return next((r for r in self.robots if r.robot == index), None)


def _stint(run: MissionRun, robot: int, phase: Phase) -> Stint | None:
    """The robot's stint that covers ``phase`` (it took off at or before its start)."""
    start, end = run.at(phase.start), run.at(phase.end)
    return next((s for s in run.stints if s.robot == robot and s.start < end
                 and s.end > start), None)


def _robot_in(run: MissionRun, robot: int, phase: Phase) -> RobotFigures | None:
    stint = _stint(run, robot, phase)
    if stint is None:
        return None
    t0, t1 = max(run.at(phase.start), stint.start), min(run.at(phase.end), stint.end)
    if t1 <= t0:
        return None
    [metrics] = window_metrics(run.frames, [robot_name(robot)], stint.start, t0, t1,
                               IMAGE_BYTES)
    return RobotFigures(robot, phase.weight_of(robot), t1 - t0, metrics)


def phase_figures(run: MissionRun) -> list[PhaseFigures]:
    """Every phase's figures, in order."""
    out = []
    for index, phase in enumerate(run.mission.phases):
        robots = tuple(f for r in phase.robots if (f := _robot_in(run, r, phase)) is not None)
        (up0, down0), (up1, down1) = run.air[index], run.air[index + 1]
        out.append(PhaseFigures(phase.name, robots, up1 - up0, down1 - down0))
    return out


def whole(run: MissionRun) -> PhaseFigures:
    """The whole mission: every (robot, phase) by its seconds."""
    phases = phase_figures(run)
    return PhaseFigures("whole mission", tuple(r for p in phases for r in p.robots),
                        run.air[-1][0] - run.air[0][0], run.air[-1][1] - run.air[0][1])


def age_series(run: MissionRun) -> tuple[list[float], list[float]]:
    """(seconds into the mission, weighted mean age of the robots flying then) every
    SAMPLE_PERIOD: the figure's line."""
    delivered = {}
    for robot in run.mission.robots:
        rows = sorted(run.frames.get(robot_name(robot), []))
        freshest, best = [], -math.inf
        for _, generated in rows:
            best = max(best, generated)
            freshest.append(best)
        delivered[robot] = ([d for d, _ in rows], freshest)
    times, ages = [], []
    steps = int(run.mission.duration / SAMPLE_PERIOD)
    for step in range(steps + 1):
        offset = step * SAMPLE_PERIOD
        phase, now = run.mission.phase_at(offset), run.at(offset)
        total = weights = 0.0
        for robot in phase.robots:
            stint = next((s for s in run.stints if s.robot == robot and s.start <= now <= s.end),
                         None)
            if stint is None:
                continue
            when, freshest = delivered[robot]
            i = bisect.bisect_right(when, now)
            generated = max(freshest[i - 1], stint.start) if i else stint.start
            total += phase.weight_of(robot) * (now - generated)
            weights += phase.weight_of(robot)
        if weights:
            times.append(offset)
            ages.append(total / weights)
    return times, ages
