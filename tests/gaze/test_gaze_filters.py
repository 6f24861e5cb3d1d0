"""The One Euro filter: passes a step, damps white noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gaze.errors import GazeError
from gaze.filters import OneEuroFilter, smoothing_factor

RATE = 60.0


def run(f: OneEuroFilter, values: np.ndarray) -> np.ndarray:
    """Filter a (N, 2) signal sampled at RATE."""
    return np.array([f(k / RATE, v) for k, v in enumerate(values)])


def test_step_converges_and_beta_cuts_lag() -> None:
    n = 120
    step = np.zeros((n, 2))
    step[30:] = [0.3, -0.2]  # a saccade-sized jump at t = 0.5 s
    out = run(OneEuroFilter(), step)
    np.testing.assert_allclose(out[:30], 0.0)
    np.testing.assert_allclose(out[-1], [0.3, -0.2], atol=1e-6)
    assert np.all(np.diff(out[30:, 0]) >= 0) and out[30:, 0].max() <= 0.3 + 1e-12  # no overshoot

    def frames_to_90(beta: float) -> int:
        o = run(OneEuroFilter(min_cutoff=1.0, beta=beta, d_cutoff=1.0), step)
        return int(np.argmax(o[:, 0] >= 0.27)) - 30

    assert frames_to_90(1.0) <= 6  # 100 ms at 60 Hz with the defaults
    assert frames_to_90(0.0) >= 3 * frames_to_90(1.0)  # the speed term is what lets saccades through


def test_white_noise_variance_reduced() -> None:
    rng = np.random.default_rng(7)
    noise = rng.normal(0.0, 0.01, size=(20000, 2))
    # beta = 0: a first-order low-pass at min_cutoff; variance ratio (2 - a) / a exactly in theory
    a = smoothing_factor(1.0, 1.0 / RATE)
    assert a == pytest.approx(1.0 / (1.0 + RATE / (2 * math.pi)))
    plain = run(OneEuroFilter(min_cutoff=1.0, beta=0.0), noise)[100:]
    assert noise.var() / plain.var() == pytest.approx((2 - a) / a, rel=0.1)  # ~20x
    # defaults: the speed term opens the cutoff a little; still at least 10x less variance
    default = run(OneEuroFilter(), noise)[100:]
    assert noise.var() / default.var() >= 10.0


def test_time_not_advancing_and_reset() -> None:
    f = OneEuroFilter()
    f(0.0, np.array([0.1, 0.1]))
    second = f(0.1, np.array([0.9, 0.9]))
    np.testing.assert_array_equal(f(0.1, np.array([0.0, 0.0])), second)
    f.reset()
    np.testing.assert_array_equal(f(0.2, np.array([0.7, 0.6])), [0.7, 0.6])


def test_bad_parameters() -> None:
    with pytest.raises(GazeError, match="min_cutoff > 0"):
        OneEuroFilter(min_cutoff=0.0)
    with pytest.raises(GazeError, match="beta >= 0"):
        OneEuroFilter(beta=-1.0)
