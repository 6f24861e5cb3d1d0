"""Peak signal-to-noise ratio on linear radiance."""

from __future__ import annotations

import math

import numpy as np


def psnr(reference_linear: np.ndarray, test_linear: np.ndarray, peak: float | None = None) -> float:
    """PSNR in dB of ``test_linear`` against ``reference_linear`` ((H, W, 3) float,
    linear radiance): ``10 log10(peak^2 / MSE)``, the MSE over every channel of every
    pixel.

    ``peak`` defaults to the reference's largest finite value.  Identical images give
    ``inf`` (even with infinities or NaNs in the same places); otherwise non-finite
    values are kept in the MSE, so an infinite difference gives ``-inf`` and a NaN
    gives NaN.
    """
    reference = np.asarray(reference_linear, dtype=np.float64)
    test = np.asarray(test_linear, dtype=np.float64)
    if reference.shape != test.shape or reference.ndim != 3 or reference.shape[2] != 3:
        raise ValueError(f"PSNR needs two (H, W, 3) images of one shape, got {reference.shape} and {test.shape}")
    if peak is None:
        finite = reference[np.isfinite(reference)]
        peak = float(finite.max()) if finite.size else math.nan
    if not (math.isfinite(peak) and peak > 0.0):
        raise ValueError(f"PSNR peak must be finite and positive, got {peak}")
    if np.array_equal(reference, test, equal_nan=True):
        return math.inf
    with np.errstate(invalid="ignore"):
        mse = float(np.mean((reference - test) ** 2))
    if not math.isfinite(mse):
        return -math.inf if mse == math.inf else math.nan
    return 10.0 * math.log10(peak * peak / mse)
