"""The acuity weight of Guenter et al. 2012's linear MAR model and the weighted mean."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.metrics import MAR_FOVEA_DEG, MAR_SLOPE, acuity_weight, foveated_mean


def test_model_constants():
    assert MAR_FOVEA_DEG == 1.0 / 48.0
    assert MAR_SLOPE == 0.022  # 1.32 arcmin per degree, the low end of the paper's range


def test_weight_follows_the_model():
    e = np.array([0.0, 1.0, 5.0, 20.0, 60.0])
    w = acuity_weight(e)
    # w0 / (w0 + m e) = 1 / (1 + 48 * 0.022 * e)
    np.testing.assert_allclose(w, [1.0, 1 / 2.056, 1 / 6.28, 1 / 22.12, 1 / 64.36], rtol=1e-12)
    np.testing.assert_allclose(w[1:3], [0.4863813229571984, 0.1592356687898089], rtol=1e-12)
    assert w[0] == 1.0
    assert np.all(np.diff(w) < 0)
    # Half weight where m e = w0.
    assert acuity_weight(MAR_FOVEA_DEG / MAR_SLOPE) == pytest.approx(0.5)
    # Other slopes and foveal MARs.
    assert acuity_weight(10.0, m=0.0275, w0=0.02) == pytest.approx(0.02 / (0.02 + 0.275))
    assert np.all(acuity_weight(e, m=0.0) == 1.0)


def test_weight_refuses_bad_input():
    with pytest.raises(ValueError):
        acuity_weight(np.array([-1.0]))
    with pytest.raises(ValueError):
        acuity_weight(1.0, w0=0.0)


def test_foveated_mean():
    weight = acuity_weight(np.linspace(0.0, 30.0, 24).reshape(4, 6))
    assert foveated_mean(np.full((4, 6), 0.3), weight) == pytest.approx(0.3, rel=1e-12)
    assert foveated_mean(np.zeros((4, 6)), weight) == 0.0
    error = np.array([[1.0, 0.0], [0.0, 0.0]])
    assert foveated_mean(error, np.array([[3.0, 1.0], [0.0, 0.0]])) == pytest.approx(0.75)
    with pytest.raises(ValueError):
        foveated_mean(error, np.zeros((2, 2)))
    with pytest.raises(ValueError):
        foveated_mean(error, np.ones((2, 3)))
