"""Tracking metrics: error in metres and pixels, time in view, control age."""

from __future__ import annotations

import math

import pytest

from wiswarm_apps.tracking.geometry import CameraModel, Pose
from wiswarm_apps.tracking.metrics import UavMetrics


def test_error_in_metres_and_pixels_and_in_view() -> None:
    camera = CameraModel(fov_deg=60.0, width=224, height=224)
    metrics = UavMetrics("u", camera)
    sample = metrics.record(1.0, Pose(5.0, 5.0, 2.0), (5.3, 5.4))
    assert sample.error_m == pytest.approx(0.5)
    assert sample.error_px == pytest.approx(0.5 / (4.0 * math.tan(math.pi / 6) / 224))
    assert sample.in_view
    assert not metrics.record(2.0, Pose(5.0, 5.0, 2.0), (7.0, 5.0)).in_view  # 2 m off
    summary = metrics.summary()
    assert summary.samples == 2 and summary.in_view_share == 0.5
    assert summary.mean_tracking_error_m == pytest.approx(1.25)


def test_control_age_counts_from_the_freshest_generation() -> None:
    metrics = UavMetrics("u", CameraModel())
    assert metrics.record(0.5, Pose(1, 1, 2), (1, 1)).control_age_s is None
    metrics.control_received(1.0)
    metrics.control_received(0.8)  # older control arriving late does not make it fresher
    assert metrics.record(1.3, Pose(1, 1, 2), (1, 1)).control_age_s == pytest.approx(0.3)
    metrics.control_received(1.4)
    assert metrics.record(1.5, Pose(1, 1, 2), (1, 1)).control_age_s == pytest.approx(0.1)
    summary = metrics.summary()
    assert summary.mean_control_age_s == pytest.approx(0.2)
    assert summary.control_updates == 3


def test_empty_summary_is_nan_not_an_error() -> None:
    summary = UavMetrics("u", CameraModel()).summary()
    assert summary.samples == 0 and math.isnan(summary.mean_tracking_error_m)
