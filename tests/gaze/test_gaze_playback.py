"""Trace playback (interpolation, blink hold), visual angles and I-VT labelling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import ArrayLike

from gaze.errors import GazeError
from gaze.screen import ScreenGeometry
from gaze.source import FIXATION, SACCADE, UNKNOWN
from gaze.trace.data import TraceData, make_trace_data
from gaze.trace.ivt import angular_speed, label_ivt
from gaze.trace.playback import TraceSource


def trace(t: ArrayLike, x: ArrayLike, y: ArrayLike, confidence: ArrayLike | None = None, t0: float = 0.0) -> TraceData:
    """A TraceData from plain sequences (NaN x = invalid), times shifted by ``t0``."""
    t = np.asarray(t, float) + t0
    confidence = np.ones_like(t) if confidence is None else np.asarray(confidence, float)
    return make_trace_data("mem.csv", "simple", t, x, y, confidence, np.ones(t.shape, bool), np.arange(2, t.size + 2))


def test_rebased_and_interpolated_at_frame_times() -> None:
    t = np.array([0.0, 0.1, 0.25, 0.3])
    x = np.array([0.0, 0.5, 0.2, 1.0])
    y = np.array([1.0, 0.5, 0.8, 0.0])
    source = TraceSource(trace(t, x, y, t0=1234.5))
    assert source.data.t[0] == 0.0 and source.duration == pytest.approx(0.3)
    frames = np.arange(0, 19) / 60.0  # 60 Hz frame times inside the trace
    got = np.array([[s.x, s.y] for s in map(source.sample, frames)])
    np.testing.assert_allclose(got[:, 0], np.interp(frames, t, x), atol=1e-12)
    np.testing.assert_allclose(got[:, 1], np.interp(frames, t, y), atol=1e-12)
    assert source.sample(0.05).x == pytest.approx(0.25)
    # before the start and after the end the first / last sample is held
    assert (source.sample(-1.0).x, source.sample(-1.0).y) == (0.0, 1.0)
    assert (source.sample(9.0).x, source.sample(9.0).y) == (1.0, 0.0)
    with pytest.raises(GazeError, match="finite"):
        source.sample(math.nan)


def test_blink_holds_last_fixation() -> None:
    n = 25
    t = np.arange(n) / 60.0
    x = np.full(n, 0.2)
    y = np.full(n, 0.3)
    x[10], y[10] = 0.5, 0.5  # in flight when the blink starts: a saccade sample
    x[11:15] = np.nan  # the blink
    x[15:], y[15:] = 0.8, 0.7
    confidence = np.ones(n)
    confidence[20] = 0.1  # a low-confidence sample is lost signal too
    source = TraceSource(trace(t, x, y, confidence))
    assert source.labels[10] == SACCADE and source.labels[8] == FIXATION
    for when in (10.5 / 60, 12 / 60, 13.7 / 60, 14.5 / 60):
        s = source.sample(when)
        assert (s.x, s.y, s.valid, s.confidence, s.label) == (0.2, 0.3, False, 0.0, UNKNOWN)
    s = source.sample(20 / 60)
    assert (s.x, s.y, s.valid, s.confidence) == (0.8, 0.7, False, 0.0)
    s = source.sample(16.5 / 60)
    assert (s.x, s.y, s.valid, s.confidence) == (0.8, 0.7, True, 1.0)


def test_invalid_start_holds_first_valid_sample() -> None:
    source = TraceSource(trace([0.0, 0.1, 0.2], [np.nan, 0.4, 0.6], [np.nan, 0.1, 0.9]))
    s = source.sample(0.0)
    assert (s.x, s.y, s.valid) == (0.4, 0.1, False)


def horizontal_x(theta_deg: np.ndarray, screen: ScreenGeometry) -> np.ndarray:
    """Normalised x of the point at ``theta_deg`` right of the screen centre (y = 0.5)."""
    return 0.5 + screen.distance_cm * np.tan(np.radians(theta_deg)) / screen.width_cm


def test_visual_angle() -> None:
    screen = ScreenGeometry(1920, 1080, 53.0, 60.0)
    assert screen.height_cm == pytest.approx(53.0 * 1080 / 1920)
    x10 = horizontal_x(np.array(10.0), screen)
    assert screen.angle_deg(0.5, 0.5, x10, 0.5) == pytest.approx(10.0, abs=1e-9)
    # symmetric points: 2 atan(w / 2d) across the full width
    full = screen.angle_deg(0.0, 0.5, 1.0, 0.5)
    assert full == pytest.approx(2 * math.degrees(math.atan(26.5 / 60.0)), abs=1e-9)
    top = screen.angle_deg(0.5, 0.0, 0.5, 1.0)
    assert top == pytest.approx(2 * math.degrees(math.atan(screen.height_cm / 2 / 60.0)), abs=1e-9)


def test_ivt_labels_synthetic_saccade() -> None:
    screen = ScreenGeometry(1920, 1080, 53.0, 60.0)
    rate = 500.0
    t = np.arange(100) / rate
    # fixation at the centre, a 10 deg saccade at 200 deg/s (samples 40..65), fixation at 10 deg
    theta = np.clip((t - 40 / rate) * 200.0, 0.0, 10.0)
    x = horizontal_x(theta, screen)
    y = np.full_like(x, 0.5)
    valid = np.ones(t.shape, bool)
    speed = angular_speed(t, x, y, valid, screen)
    np.testing.assert_allclose(speed[41:65], 200.0, rtol=1e-9)
    np.testing.assert_allclose(speed[:40], 0.0, atol=1e-9)
    np.testing.assert_allclose(speed[66:], 0.0, atol=1e-9)
    assert speed[40] == pytest.approx(100.0) and speed[65] == pytest.approx(100.0)  # half-in central differences
    labels = label_ivt(t, x, y, valid, screen, threshold_deg_s=30.0)
    expected = np.where((np.arange(100) >= 40) & (np.arange(100) <= 65), SACCADE, FIXATION)
    np.testing.assert_array_equal(labels, expected)


def test_ivt_depends_on_viewing_distance() -> None:
    near = ScreenGeometry(1920, 1080, 53.0, 30.0)
    far = ScreenGeometry(1920, 1080, 53.0, 60.0)
    t = np.arange(50) / 250.0
    x = horizontal_x(t * 20.0, far)  # a 20 deg/s drift seen from 60 cm: a fixation
    y = np.full_like(x, 0.5)
    valid = np.ones(t.shape, bool)
    far_speed = angular_speed(t, x, y, valid, far)
    near_speed = angular_speed(t, x, y, valid, near)
    np.testing.assert_allclose(far_speed, 20.0, rtol=1e-9)
    # the same screen movement from half the distance: tan(theta') = 2 tan(theta), about twice as fast
    assert near_speed.min() > 38.0 and near_speed.max() < 40.0
    assert set(label_ivt(t, x, y, valid, far)) == {FIXATION}
    assert set(label_ivt(t, x, y, valid, near)) == {SACCADE}


def test_ivt_invalid_and_isolated_samples_unknown() -> None:
    screen = ScreenGeometry()
    t = np.arange(5) * 0.01
    x = np.array([0.5, 0.5, np.nan, 0.5, 0.5])
    valid = np.array([True, False, False, True, True])
    labels = label_ivt(t, x, np.full(5, 0.5), valid, screen)
    np.testing.assert_array_equal(labels, [UNKNOWN, UNKNOWN, UNKNOWN, FIXATION, FIXATION])
