"""Weighting an error map by the eye's acuity around the gaze point.

Guenter et al. 2012, "Foveated 3D graphics": the minimum angle of resolution grows
linearly with eccentricity, ``MAR(e) = w0 + m e`` (degrees), with the paper's
foveal ``w0 = 1/48`` deg (1.25 arcmin) and a slope their user study puts at
1.32-1.65 arcmin per degree (m = 0.022-0.0275).  Acuity is proportional to
``1 / MAR``, so an error at eccentricity ``e`` weighs, relative to one at the gaze,

    weight(e) = MAR(0) / MAR(e) = w0 / (w0 + m e),

1 at the gaze point, falling hyperbolically (one half at ``e = w0 / m``).  The default
slope is the low end of the paper's range, m = 0.022: acuity falls the slowest there,
so the foveated score discounts errors away from the gaze the least.
"""

from __future__ import annotations

import numpy as np

MAR_FOVEA_DEG = 1.0 / 48.0
MAR_SLOPE = 0.022


def acuity_weight(eccentricity_deg: np.ndarray, m: float = MAR_SLOPE, w0: float = MAR_FOVEA_DEG) -> np.ndarray:
    """``w0 / (w0 + m e)`` for eccentricities ``e`` >= 0 in degrees (any shape, float64)."""
    if not (m >= 0.0 and w0 > 0.0):
        raise ValueError(f"MAR slope must be >= 0 and foveal MAR > 0, got m={m}, w0={w0}")
    e = np.asarray(eccentricity_deg, dtype=np.float64)
    if np.any(e < 0.0):
        raise ValueError("eccentricities must be >= 0 degrees")
    return w0 / (w0 + m * e)


def foveated_mean(error_map: np.ndarray, weight: np.ndarray) -> float:
    """The weighted mean ``sum(w * err) / sum(w)`` of an error map (weights of its shape,
    >= 0, not all 0)."""
    error = np.asarray(error_map, dtype=np.float64)
    w = np.asarray(weight, dtype=np.float64)
    if error.shape != w.shape:
        raise ValueError(f"error map and weights differ in shape: {error.shape} vs {w.shape}")
    total = float(w.sum())
    if np.any(w < 0.0) or not total > 0.0:
        raise ValueError("weights must be >= 0 with a positive sum")
    return float((w * error).sum() / total)
