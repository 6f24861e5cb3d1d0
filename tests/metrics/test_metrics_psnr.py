"""PSNR on linear radiance against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from warp_hybrid.metrics import psnr


def _known_linear(h: int = 16, w: int = 24) -> np.ndarray:
    """A deterministic linear image with values in [0, 4]."""
    y, x = np.mgrid[0:h, 0:w]
    return np.stack([x / (w - 1) * 4.0, y / (h - 1) * 2.0, np.full((h, w), 0.5)], axis=-1)


def test_identical_images_are_infinite():
    image = _known_linear()
    assert psnr(image, image.copy()) == math.inf
    image[1, 2] = (np.inf, np.nan, 0.0)
    assert psnr(image, image.copy()) == math.inf


def test_constant_offset():
    image = _known_linear()
    # MSE = 0.1^2, peak = 4: 20 log10(4 / 0.1) = 32.0412 dB.
    assert psnr(image, image + 0.1) == pytest.approx(20 * math.log10(4.0 / 0.1), rel=1e-12)
    assert psnr(image, image - 0.1) == pytest.approx(32.04119982655925, rel=1e-12)
    assert psnr(image, image + 0.1, peak=1.0) == pytest.approx(20.0, rel=1e-12)


def test_non_finite_values_stay_in_the_mse():
    image = _known_linear()
    reference = image.copy()
    reference[0, 0, 2] = np.inf
    # The default peak skips the inf (an infinite peak would be refused), the MSE does not.
    assert psnr(reference, image) == -math.inf
    test = image.copy()
    test[3, 4, 0] = np.nan
    assert math.isnan(psnr(image, test))


def test_bad_inputs_are_refused():
    image = _known_linear()
    with pytest.raises(ValueError, match="shape"):
        psnr(image, image[:, :-1])
    with pytest.raises(ValueError, match="peak"):
        psnr(np.zeros_like(image), image)
