"""The ROS 2 air benchmark's pieces that need no root: the throttle at the robot, the
topics the ground subscribes to, what polls and replies need of the channel."""

from __future__ import annotations

import itertools

import pytest

from wiswarm_zenoh.experiments.ros2_air import AirCase, CaseResult
from wiswarm_zenoh.experiments.ros2_air_nodes import Throttle
from wiswarm_zenoh.experiments.ros2_air_report import (
    HEADER_BYTES,
    SEGMENT_BYTES,
    floor_s,
    needed_bytes,
    on_wire,
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


def test_no_throttle_keeps_every_frame_and_a_bad_rate_is_refused() -> None:
    assert _passed(None, 10) == list(range(10))
    with pytest.raises(ValueError, match="max_hz"):
        Throttle(0.0)


def test_the_ground_subscribes_to_the_robots_topics_or_the_leaders() -> None:
    assert AirCase("direct", 2).topic(2) == "/drone2/camera/image_raw/compressed"
    assert AirCase("wiswarm", 2).topic(2) == \
        "/wiswarm/air/d2/drone2/camera/image_raw/compressed"
    with pytest.raises(ValueError, match="max_hz"):
        AirCase("direct", 2, 5.0)


def _wiswarm(frames: int, replies: int, polls: float) -> CaseResult:
    robot = FollowerMetrics("drone1", 0.1, 0.2, 0.3, frames, frames / 10.0, 0.0)
    return CaseResult("tbf", AirCase("wiswarm", 2), 10.0, [robot], 0, 0, replies,
                      replies * 50_000, polls)


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
