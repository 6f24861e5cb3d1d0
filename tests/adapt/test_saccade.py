"""The saccade landing predictor on synthetic saccades with a known main-sequence profile."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gaze.screen import ScreenGeometry
from gaze.source import FIXATION, SACCADE, GazeSample
from gaze.trace.ivt import label_ivt
from warp_hybrid.adapt.saccade import MainSequence, SaccadePredictor, offset_by_angle
from warp_hybrid.errors import RenderSettingsError

SCREEN = ScreenGeometry()
V_MAX, C = 600.0, 6.0  # the predictor's main sequence (Dai et al. 2016)
#: (amplitude deg, axis) from the screen centre; down, the screen ends 13.9 deg away
CASES = [(a, "x") for a in (4.0, 8.0, 12.0, 16.0)] + [(a, "y") for a in (4.0, 8.0, 12.0)]


def dai_angle(t: np.ndarray, amplitude: float, v_max: float = V_MAX, c: float = C) -> np.ndarray:
    """Dai et al.'s parametric saccade (IEEE SPMB 2016): the angle (deg) at ``t`` s after
    its onset parameter; its peak speed is exactly ``v_max (1 - exp(-A / c))``."""

    def f(u: np.ndarray) -> np.ndarray:
        return np.where(u >= 0.0, u + 0.25 * np.exp(-2.0 * np.abs(u)), 0.25 * np.exp(-2.0 * np.abs(u)))

    tau = amplitude / v_max
    return c * f(v_max * t / c) - c * f(v_max * (t - tau) / c)


def saccade_track(amplitude: float, axis: str, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple]:
    """Samples (t, x, y) of a saccade from the screen centre, right (``"x"``) or down (``"y"``),
    at ``rate`` Hz, and its true end point: exact flat-screen geometry (tan), no predictor code."""
    t = np.arange(-0.06, 0.2, 1.0 / rate)
    theta = dai_angle(t, amplitude)
    x, y = np.full(t.shape, 0.5), np.full(t.shape, 0.5)
    size = SCREEN.width_cm if axis == "x" else SCREEN.height_cm
    shift = SCREEN.distance_cm * np.tan(np.radians(theta)) / size
    end = 0.5 + SCREEN.distance_cm * math.tan(math.radians(amplitude)) / size
    if axis == "x":
        return t, x + shift, y, (end, 0.5)
    return t, x, y + shift, (0.5, end)


def predictions(t: np.ndarray, x: np.ndarray, y: np.ndarray, predictor: SaccadePredictor) -> list[tuple]:
    """Feed the I-VT-labelled samples one by one: per sample with a landing, (index, landing)."""
    labels = label_ivt(t, x, y, np.ones(t.shape, bool), SCREEN)
    out = []
    for i in range(t.size):
        predictor.add(GazeSample(float(x[i]), float(y[i]), float(t[i]), label=str(labels[i])))
        landing = predictor.landing()
        if landing is not None:
            assert labels[i] == SACCADE
            out.append((i, landing))
    return out


def test_main_sequence_inverts_its_peak_speed_and_caps_near_saturation() -> None:
    ms = MainSequence()
    for amplitude in (0.5, 2.0, 5.0, 10.0, 15.0):
        assert ms.amplitude(ms.peak_speed(amplitude)) == pytest.approx(amplitude, rel=1e-12)
    assert ms.peak_speed(10.0) == pytest.approx(600.0 * (1.0 - math.exp(-10.0 / 6.0)))
    cap = -6.0 * math.log(0.05)  # V / v_max capped at 0.95: about 18 deg
    assert ms.amplitude(599.0) == pytest.approx(cap) and ms.amplitude(1e9) == pytest.approx(cap)
    assert ms.amplitude(-5.0) == 0.0
    for bad in ({"v_max_deg_s": 0.0}, {"c_deg": math.nan}, {"max_share": 1.0}):
        with pytest.raises(RenderSettingsError):
            MainSequence(**bad)


@pytest.mark.parametrize("start", [(0.5, 0.5), (0.2, 0.7), (0.9, 0.1)])
@pytest.mark.parametrize("direction", [(1.0, 0.0), (-0.3, 0.8), (0.5, -0.5)])
def test_offset_by_angle_is_that_visual_angle_along_the_line(start: tuple, direction: tuple) -> None:
    for angle in (0.5, 3.0, 8.0):
        end = offset_by_angle(SCREEN, start, direction, angle)
        if 0.0 < end[0] < 1.0 and 0.0 < end[1] < 1.0:
            assert float(SCREEN.angle_deg(*start, *end)) == pytest.approx(angle, rel=1e-9)
        d = np.subtract(end, start)
        assert d[0] * direction[1] - d[1] * direction[0] == pytest.approx(0.0, abs=1e-12)  # on the line
        assert d @ np.asarray(direction) > 0.0  # and forwards


def test_offset_by_angle_stops_at_the_screen_edge() -> None:
    end = offset_by_angle(SCREEN, (0.5, 0.5), (1.0, 0.5), 40.0)  # 40 deg to the right: off the screen
    assert end[0] == pytest.approx(1.0) and end[1] == pytest.approx(0.75)
    far = offset_by_angle(SCREEN, (0.9, 0.5), (1.0, 0.0), 89.0)  # past the horizon of the line
    assert far == pytest.approx((1.0, 0.5))


def errors_against(t: np.ndarray, x: np.ndarray, y: np.ndarray, end: tuple, found: list[tuple]) -> np.ndarray:
    """Per landing: (predicted error, the gaze's error, peak passed), angles in deg from the true end."""
    return np.array(
        [
            (
                float(SCREEN.angle_deg(*landing.point, *end)),
                float(SCREEN.angle_deg(x[i], y[i], *end)),
                landing.peak_passed,
            )
            for i, landing in found
        ]
    )


@pytest.mark.parametrize("rate", [60.0, 120.0, 250.0, 1000.0])
@pytest.mark.parametrize(("amplitude", "axis"), CASES)
def test_never_lands_behind_the_gaze(rate: float, amplitude: float, axis: str) -> None:
    t, x, y, end = saccade_track(amplitude, axis, rate)
    found = predictions(t, x, y, SaccadePredictor(SCREEN))
    assert found, "the saccade was labelled and seen moving"
    # from discrete samples the peak speed is at most the true one: the amplitude is never
    # overestimated, so the prediction lies between the gaze and the end point
    assert max(landing.amplitude_deg for _, landing in found) <= amplitude + 1e-6
    err = errors_against(t, x, y, end, found)
    assert np.all(err[:, 0] <= err[:, 1] + 1e-9)


@pytest.mark.parametrize("rate", [250.0, 500.0, 1000.0])
@pytest.mark.parametrize(("amplitude", "axis"), CASES)
def test_lands_near_the_true_end_point_once_the_peak_passed(rate: float, amplitude: float, axis: str) -> None:
    t, x, y, end = saccade_track(amplitude, axis, rate)
    err = errors_against(t, x, y, end, predictions(t, x, y, SaccadePredictor(SCREEN)))
    after = err[err[:, 2] == 1.0]
    assert after.size, "the peak passed while the saccade was still labelled"
    assert after[:, 0].max() <= 0.3  # deg: once the speed falls, the main sequence gives the amplitude
    assert after[:, 0].mean() <= 0.6 * after[:, 1].mean()
    assert err[:, 0].mean() <= 0.8 * err[:, 1].mean()  # over the whole saccade too


def test_oblique_saccades_keep_their_direction() -> None:
    rate, amplitude = 500.0, 10.0
    start, direction = (0.3, 0.35), (0.8, 0.6)
    t = np.arange(-0.06, 0.2, 1.0 / rate)
    points = np.array([offset_by_angle(SCREEN, start, direction, a) for a in dai_angle(t, amplitude)])
    end = offset_by_angle(SCREEN, start, direction, amplitude)
    found = predictions(t, points[:, 0], points[:, 1], SaccadePredictor(SCREEN))
    last = found[-1][1]
    assert last.peak_passed and float(SCREEN.angle_deg(*last.point, *end)) < 0.1


def test_no_landing_without_a_saccade_in_flight() -> None:
    p = SaccadePredictor(SCREEN)
    p.add(GazeSample(0.4, 0.4, 0.0, label=FIXATION))
    assert p.landing() is None
    p.add(GazeSample(0.4, 0.4, 0.01, label=SACCADE))  # labelled, but the eye has not moved yet
    assert p.landing() is None
    p.add(GazeSample(0.45, 0.4, 0.02, label=SACCADE))
    first = p.landing()
    assert first is not None and first.x > 0.45 and first.y == pytest.approx(0.4)
    p.add(GazeSample(0.9, 0.9, 0.02, label=SACCADE))  # not later than the last sample: ignored
    assert p.landing() == first
    p.add(GazeSample(0.5, 0.4, 0.03, valid=False))  # track lost: the saccade is forgotten
    p.add(GazeSample(0.55, 0.4, 0.04, label=SACCADE))
    assert p.landing() is None  # its onset is this sample: no movement seen yet
    p.add(GazeSample(0.6, 0.4, 0.05, label=FIXATION))
    assert p.landing() is None


def test_a_saccade_from_the_first_sample_starts_there() -> None:
    p = SaccadePredictor(SCREEN)
    p.add(GazeSample(0.3, 0.5, 0.0, label=SACCADE))
    assert p.landing() is None
    for k in range(1, 4):
        p.add(GazeSample(0.3 + 0.02 * k, 0.5, 0.004 * k, label=SACCADE))
    landing = p.landing()
    covered = float(SCREEN.angle_deg(0.3, 0.5, 0.36, 0.5))
    assert landing is not None and math.isfinite(landing.amplitude_deg) and landing.amplitude_deg >= covered
    assert landing.y == pytest.approx(0.5) and landing.x >= 0.36
