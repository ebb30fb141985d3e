"""The ROS 2 air benchmark's pieces that need no root: the throttle at the robot, the
topics the ground subscribes to, what polls and replies need of the channel."""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
from pathlib import Path

import pytest

from wiswarm_zenoh.experiments import ros2_air
from wiswarm_zenoh.experiments.ros2_air import AirCase, AirConfig, AirResults, CaseResult
from wiswarm_zenoh.experiments.ros2_air_nodes import Throttle, throttled_hz
from wiswarm_zenoh.experiments.ros2_air_report import (
    HEADER_BYTES,
    SEGMENT_BYTES,
    floor_s,
    needed_bytes,
    on_wire,
    plot,
    report,
)
from wiswarm_zenoh.sim.metrics import FollowerMetrics


def _passed(max_hz: float | None, frames: int, rate: float = 30.0) -> list[int]:
    throttle = Throttle(max_hz)
    return [k for k in range(frames) if throttle.passes(k / rate)]


@pytest.mark.parametrize(("max_hz", "every"), [(15.0, 2), (10.0, 3), (7.5, 4), (5.0, 6),
                                                (3.0, 10)])
def test_a_throttle_at_a_divisor_of_the_camera_rate_keeps_every_kth_frame(
        max_hz: float, every: int) -> None:
    assert _passed(max_hz, 60) == list(range(0, 60, every))


def test_a_throttle_between_divisors_keeps_the_first_frame_after_each_period() -> None:
    # 4 Hz from 30 Hz: a period of 7.5 frames, so gaps of 8 frames (never 7)
    passed = _passed(4.0, 60)
    assert {b - a for a, b in itertools.pairwise(passed)} == {8}


@pytest.mark.parametrize("max_hz", [30.0, 29.0, 15.0, 7.5, 7.2, 5.0, 4.0, 2.2, 0.5])
def test_what_a_throttle_passes_is_every_kth_frame(max_hz: float) -> None:
    """What (b)'s search runs a rate at: the throttle's own rate of passing frames."""
    passed = _passed(max_hz, 600)
    gaps = {b - a for a, b in itertools.pairwise(passed)}
    assert gaps == {round(30.0 / throttled_hz(max_hz))}
    assert throttled_hz(throttled_hz(max_hz)) == throttled_hz(max_hz)


def test_no_throttle_keeps_every_frame_and_a_bad_rate_is_refused() -> None:
    assert _passed(None, 10) == list(range(10))
    with pytest.raises(ValueError, match="max_hz"):
        Throttle(0.0)


def test_the_ground_subscribes_to_the_robots_topics_or_the_leaders() -> None:
    assert AirCase("direct", 2).topic(2) == "/drone2/camera/image_raw/compressed"
    for republished in ("wiswarm", "newest"):
        assert AirCase(republished, 2).topic(2) == \
            "/wiswarm/air/d2/drone2/camera/image_raw/compressed"
    with pytest.raises(ValueError, match="max_hz"):
        AirCase("direct", 2, 5.0)


def _run(case: AirCase, mean_aoi: float, frames: int, up_bytes: int = 0,
         replies: int = 0, polls: float = 0.0) -> CaseResult:
    robot = FollowerMetrics("drone1", mean_aoi, mean_aoi * 2, mean_aoi * 3, frames,
                            frames / 10.0, 0.0)
    return CaseResult("tbf", case, 10.0, [robot], up_bytes, 0, replies, replies * 50_000,
                      polls)


def _wiswarm(frames: int, replies: int, polls: float) -> CaseResult:
    return _run(AirCase("wiswarm", 2), 0.1, frames, 0, replies, polls)


def test_what_polls_and_replies_need_counts_segments_and_headers() -> None:
    assert on_wire(SEGMENT_BYTES) == SEGMENT_BYTES + HEADER_BYTES
    assert on_wire(SEGMENT_BYTES + 1) == SEGMENT_BYTES + 1 + 2 * HEADER_BYTES
    up, down = needed_bytes(_wiswarm(100, 100, 100.0))
    assert 100 * 50_000 * 1.04 < up < 100 * 50_000 * 1.06  # a 50 kB reply: 35 segments
    assert 0 < down < up * 0.05
    more_up, more_down = needed_bytes(_wiswarm(100, 100, 150.0))  # 50 polls found nothing
    assert more_up > up and more_down > down


def test_the_floor_is_s_times_half_n_plus_one() -> None:
    # 200 frames in 10 s: S = 50 ms; N = 2: the floor is 2 S
    assert floor_s(_wiswarm(200, 200, 200.0)) == pytest.approx(0.1)


def test_the_report_judges_each_target_and_draws_the_figure(tmp_path: Path) -> None:
    """N = 8: (c) at 1.1 x the floor, its bytes what its replies need; (a) 20 x (c),
    (b)'s best 1.2 x (c): every target met but (b)'s."""
    # 8 robots, 400 frames in 10 s: S = 25 ms, the floor 125 ms
    robots = [FollowerMetrics("drone1", 0.1375, 0.2, 0.3, 50, 5.0, 0.0)] * 8
    counted = CaseResult("tbf", AirCase("wiswarm", 8), 10.0, robots, 0, 0, 400,
                         400 * 50_000, 400.0)
    up, down = needed_bytes(counted)
    c = dataclasses.replace(counted, up_bytes=round(up), down_bytes=round(down))
    results = AirResults([c, _run(AirCase("direct", 8), 0.1375 * 20, 10),
                          _run(AirCase("throttled", 8, 5.0), 0.1375 * 1.2, 50),
                          _run(AirCase("newest", 8), 0.1375 * 2, 40)],
                         {("tbf", 8): 5.0}, {("tbf", 8): 6.4})
    text = report(results)
    assert "(b) throttled 5 Hz (best)" in text
    assert "| tbf | 8 | 6.4 | 5: 165 | 5 |" in text
    assert "| tbf | 8 | (d) newest-only push | 275 |" in text
    assert "(c) 1.10 x the floor (target <= 1.2): met" in text
    assert "(a)/(c) 20.0 (target >= 20): met" in text
    assert "(b)/(c) 1.20 (target >= 1.5): MISSED" in text
    assert "(c)'s bytes 0 % off what polls and replies need (target <= 10 %): met" in text
    plot(tmp_path / "air.png", results)
    assert (tmp_path / "air.png").stat().st_size > 10_000


def test_b_is_searched_finely_from_the_share_each_throttle_run_once(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """(a) and (c) once, then (b) at the throttles the fine search asks for, each rate
    the throttle gives run once; the best is one of them, near the cliff (5.6 Hz)."""
    measured: list[AirCase] = []

    def measure_case(medium: object, name: str, case: AirCase, *_: object) -> CaseResult:
        measured.append(case)
        hz = case.max_hz or 30.0
        return _run(case, 1 / hz if hz < 5.6 else hz, 10)

    monkeypatch.setattr(ros2_air, "measure_case", measure_case)
    monkeypatch.setattr(ros2_air, "Channel", lambda spec: contextlib.nullcontext(None))
    config = AirConfig(ns=(8,), media=("tbf",))
    results = ros2_air.run_air(config, tmp_path)
    assert [c.kind for c in measured[:3]] == ["direct", "wiswarm", "newest"]
    rates = [c.max_hz for c in measured[3:]]
    assert len(rates) == len(set(rates)) and all(r == throttled_hz(r) for r in rates)
    assert results.best[("tbf", 8)] == 5.0  # every 6th frame: the last below the cliff
    assert results.share[("tbf", 8)] == config.share_fps("tbf", 8)
    assert results.tried("tbf", 8) == [(r, pytest.approx(1 / r if r < 5.6 else r))
                                       for r in rates]
