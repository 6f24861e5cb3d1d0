"""FLIP through NVIDIA's evaluator: zero on identical images, the library's own result
at the set-up's pixels per degree otherwise."""

from __future__ import annotations

import flip_evaluator
import numpy as np
import pytest

from warp_hybrid.metrics import ViewingSetup, flip_map


def _known_image(h: int = 32, w: int = 48) -> np.ndarray:
    """A deterministic uint8 sRGB image: colour ramps and a checker."""
    y, x = np.mgrid[0:h, 0:w]
    checker = ((x // 4 + y // 4) % 2) * 60
    return np.stack([x * 255 // (w - 1), y * 255 // (h - 1), 40 + checker], axis=-1).astype(np.uint8)


def test_identical_images_score_zero():
    image = _known_image()
    error = flip_map(image, image.copy(), ViewingSetup())
    assert error.shape == image.shape[:2]
    assert error.dtype == np.float32
    assert np.all(error == 0.0)


def test_known_difference_equals_the_library_at_the_setups_ppd():
    reference = _known_image()
    test = reference.copy()
    test[8:16, 10:30] = 255 - test[8:16, 10:30]
    viewing = ViewingSetup()
    error = flip_map(reference, test, viewing)
    assert error.max() > 0.1
    # 48 px across the default screen: 0.60 * 48 / 0.53 * pi / 180 = 0.948405 px/deg.
    ppd = 0.948405329385598
    assert viewing.pixels_per_degree(48) == pytest.approx(ppd, rel=1e-12)
    direct, mean, params = flip_evaluator.evaluate(
        reference.astype(np.float32) / 255,
        test.astype(np.float32) / 255,
        "LDR",
        applyMagma=False,
        parameters={"ppd": ppd},
    )
    assert params["ppd"] == pytest.approx(ppd)
    np.testing.assert_array_equal(error, direct[..., 0])
    assert float(error.mean(dtype=np.float64)) == pytest.approx(mean, rel=1e-5)
    # The same as FLIP's own viewing conditions (distance, width in px, width in m).
    by_vc, _, _ = flip_evaluator.evaluate(
        reference.astype(np.float32) / 255, test.astype(np.float32) / 255, "LDR", applyMagma=False,
        parameters={"vc": [0.60, 48, 0.53]},
    )  # fmt: skip
    np.testing.assert_allclose(error, by_vc[..., 0], atol=1e-6)
    # Not the library's default 67 ppd.
    default, _, _ = flip_evaluator.evaluate(
        reference.astype(np.float32) / 255, test.astype(np.float32) / 255, "LDR", applyMagma=False
    )
    assert not np.allclose(error, default[..., 0])


def test_error_stays_where_the_difference_is():
    reference = np.full((40, 40, 3), 128, np.uint8)
    test = reference.copy()
    test[:4, :4] = (255, 0, 0)  # row 0 is the top: the top-left corner
    error = flip_map(reference, test, ViewingSetup(distance_m=3.0))
    row, col = np.unravel_index(np.argmax(error), error.shape)
    assert row < 4 and col < 4
    assert error[30:, 30:].max() == 0.0


def test_wrong_inputs_are_refused():
    image = _known_image()
    with pytest.raises(ValueError, match="uint8"):
        flip_map(image.astype(np.float32), image, ViewingSetup())
    with pytest.raises(ValueError, match="shape"):
        flip_map(image, image[:, :-1], ViewingSetup())
