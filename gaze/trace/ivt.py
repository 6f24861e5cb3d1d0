"""Fixation / saccade labelling by a velocity threshold (I-VT, Salvucci and Goldberg 2000)."""

from __future__ import annotations

import numpy as np

from gaze.screen import ScreenGeometry
from gaze.source import FIXATION, SACCADE, UNKNOWN

#: Angular speed (deg/s) above which a sample is a saccade (Tobii's I-VT default).
DEFAULT_THRESHOLD_DEG_S = 30.0


def angular_speed(t: np.ndarray, x: np.ndarray, y: np.ndarray, valid: np.ndarray, screen: ScreenGeometry) -> np.ndarray:
    """Eye speed in degrees per second at each sample (NaN where it cannot be measured).

    A central difference over the two neighbours where both are valid, otherwise a
    one-sided difference to the valid neighbour; a valid sample with no valid
    neighbour, and every invalid sample, gets NaN.
    """
    n = t.shape[0]
    speed = np.full(n, np.nan)
    if n < 2:
        return speed
    prev_ok = np.zeros(n, bool)
    next_ok = np.zeros(n, bool)
    prev_ok[1:] = valid[1:] & valid[:-1]
    next_ok[:-1] = valid[:-1] & valid[1:]
    lo = np.where(prev_ok, np.arange(n) - 1, np.arange(n))
    hi = np.where(next_ok, np.arange(n) + 1, np.arange(n))
    measurable = valid & (lo != hi)
    lo, hi = lo[measurable], hi[measurable]
    angle = screen.angle_deg(x[lo], y[lo], x[hi], y[hi])
    speed[measurable] = angle / (t[hi] - t[lo])
    return speed


def label_ivt(
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    valid: np.ndarray,
    screen: ScreenGeometry,
    threshold_deg_s: float = DEFAULT_THRESHOLD_DEG_S,
) -> np.ndarray:
    """Per-sample labels: ``"fixation"`` below the threshold, ``"saccade"`` at or above it,
    ``"unknown"`` where the speed cannot be measured (invalid samples, isolated ones)."""
    t, x, y = (np.asarray(a, dtype=float) for a in (t, x, y))
    speed = angular_speed(t, x, y, np.asarray(valid, dtype=bool), screen)
    labels = np.full(speed.shape, UNKNOWN, dtype=object)
    measured = np.isfinite(speed)
    labels[measured & (speed < threshold_deg_s)] = FIXATION
    labels[measured & (speed >= threshold_deg_s)] = SACCADE
    return labels
