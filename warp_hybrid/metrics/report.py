"""One frame's error against a reference: FLIP overall, foveated, inside and outside the
focus window, and PSNR on linear radiance."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .flip import flip_map
from .foveation import acuity_weight, foveated_mean
from .psnr import psnr
from .viewing import ViewingSetup

if TYPE_CHECKING:
    from warp_hybrid.focus.window import WindowLayout


@dataclass(frozen=True)
class ErrorReport:
    """A test frame's error against its reference.

    ``flip_mean``: mean FLIP over all pixels; ``flip_foveated``: FLIP weighted by the
    acuity falloff around the gaze (``foveation.acuity_weight``); ``flip_inside`` /
    ``flip_outside``: mean FLIP over the focus window's pixels and over the rest (NaN
    where a region has no pixel); ``psnr``: dB on linear radiance (inf when equal).
    """

    flip_mean: float
    flip_foveated: float
    flip_inside: float
    flip_outside: float
    psnr: float


def layout_mask(layout: WindowLayout) -> np.ndarray:
    """(H, W) bool: the pixels a placed focus window covers, from
    ``FocusWindow(...).layout(W, H)`` (a ``focus.WindowLayout``) and its ``row_spans``."""
    start, stop = layout.row_spans()
    cols = np.arange(layout.width)
    return (cols[None, :] >= start[:, None]) & (cols[None, :] < stop[:, None])


def _region_mean(error_map: np.ndarray, mask: np.ndarray) -> float:
    """Mean of ``error_map`` where ``mask`` holds; NaN for an empty region."""
    return float(error_map[mask].mean()) if mask.any() else math.nan


def evaluate(
    reference_srgb: np.ndarray,
    test_srgb: np.ndarray,
    reference_linear: np.ndarray,
    test_linear: np.ndarray,
    gaze: tuple[float, float],
    window_mask: np.ndarray | None = None,
    viewing: ViewingSetup = ViewingSetup(),
) -> ErrorReport:
    """The ``ErrorReport`` of a test frame against a reference frame.

    FLIP on the uint8 (H, W, 3) sRGB images (``flip.flip_map`` at ``viewing``'s pixels
    per degree), PSNR on the (H, W, 3) linear images (peak: the reference's largest
    finite value), the foveated FLIP around ``gaze`` (normalised, origin top-left).
    ``window_mask`` (H, W) bool marks the focus window's pixels (``layout_mask`` makes it);
    None means no window: ``flip_inside`` is NaN and ``flip_outside`` the mean.
    """
    error = flip_map(reference_srgb, test_srgb, viewing)
    if window_mask is None:
        window_mask = np.zeros(error.shape, dtype=bool)
    mask = np.asarray(window_mask)
    if mask.dtype != np.bool_ or mask.shape != error.shape:
        raise ValueError(f"window mask must be a bool array of shape {error.shape}, got {mask.dtype} {mask.shape}")
    linear_shape = np.shape(reference_linear)[:2]
    if linear_shape != error.shape:
        raise ValueError(f"linear images are {linear_shape}, the sRGB images {error.shape}")
    weight = acuity_weight(viewing.eccentricity_deg(error.shape, gaze))
    return ErrorReport(
        flip_mean=float(error.mean(dtype=np.float64)),
        flip_foveated=foveated_mean(error, weight),
        flip_inside=_region_mean(error, mask),
        flip_outside=_region_mean(error, ~mask),
        psnr=psnr(reference_linear, test_linear),
    )
