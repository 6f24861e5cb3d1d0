"""The viewing set-up: the gaze package's defaults, FLIP's pixels per degree, exact
eccentricities."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gaze.screen import ScreenGeometry
from warp_hybrid.metrics import ViewingSetup


def test_defaults_are_the_gaze_screen():
    viewing = ViewingSetup()
    screen = ScreenGeometry()
    assert (viewing.screen_width_px, viewing.screen_width_m, viewing.distance_m) == (1920, 0.53, 0.60)
    assert viewing.screen_width_px == screen.width_px
    assert viewing.screen_width_m * 100 == pytest.approx(screen.width_cm)
    assert viewing.distance_m * 100 == pytest.approx(screen.distance_cm)


def test_pixels_per_degree_by_hand():
    # 0.60 m * (1920 px / 0.53 m) * pi / 180 = 37.9362 px/deg on the full screen.
    viewing = ViewingSetup()
    assert viewing.pixels_per_degree(1920) == pytest.approx(37.936213175423916, rel=1e-12)
    # A 640 px image stretched over the same screen: a third of that.
    assert viewing.pixels_per_degree(640) == pytest.approx(12.64540439180797, rel=1e-12)
    # FLIP's own example viewing conditions (0.7 m, 3840 px, 0.7 m wide) give its default 67 ppd.
    assert ViewingSetup(3840, 0.7, 0.7).pixels_per_degree(3840) == pytest.approx(67.02, abs=0.01)


def test_bad_setups_are_refused():
    with pytest.raises(ValueError):
        ViewingSetup(distance_m=0.0)
    with pytest.raises(ValueError):
        ViewingSetup().pixels_per_degree(0)
    with pytest.raises(ValueError):
        ViewingSetup().eccentricity_deg((4, 4), (math.nan, 0.5))


def test_eccentricity_is_zero_at_the_gaze_pixel_centre():
    h, w = 6, 10
    j, i = 2, 7
    ecc = ViewingSetup().eccentricity_deg((h, w, 3), ((i + 0.5) / w, (j + 0.5) / h))
    assert ecc.shape == (h, w)
    assert ecc[j, i] == 0.0
    assert np.all(np.delete(ecc.ravel(), j * w + i) > 0.0)


def test_eccentricity_is_symmetric_about_a_centred_gaze():
    ecc = ViewingSetup().eccentricity_deg((8, 12), (0.5, 0.5))
    np.testing.assert_allclose(ecc, ecc[::-1, :], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ecc, ecc[:, ::-1], rtol=0, atol=1e-12)


def test_eccentricity_by_hand():
    viewing = ViewingSetup()
    # 4x2 image on the 0.53 m screen (0.265 m tall): pixel (0, 0) is 0.19875 m left and
    # 0.06625 m above the centre, atan(0.2095 / 0.60) = 19.2476 deg from a centred gaze.
    ecc = viewing.eccentricity_deg((2, 4), (0.5, 0.5))
    assert ecc[0, 0] == pytest.approx(19.247575506997972, rel=1e-12)
    # Off-centre gaze, exact angle between the rays: gaze at the left edge, middle row,
    # the screen centre is on the axis, so the angle is atan(0.265 / 0.60) = 23.8294 deg.
    ecc = viewing.eccentricity_deg((3, 2), (0.0, 0.5))
    assert ecc[1, :].max() > ecc[1, 0]
    ecc_centre = viewing.eccentricity_deg((1, 1), (0.0, 0.5))
    assert ecc_centre[0, 0] == pytest.approx(23.829449477964832, rel=1e-12)
