"""FLIP (Andersson et al. 2020) between tone-mapped 8-bit sRGB images, through NVIDIA's
own evaluator (``flip_evaluator``) rather than a reimplementation of the metric."""

from __future__ import annotations

import flip_evaluator
import numpy as np

from .viewing import ViewingSetup


def _srgb_unit(image: np.ndarray, name: str) -> np.ndarray:
    """A uint8 (H, W, 3) sRGB image as float32 in [0, 1], C-contiguous, as FLIP's LDR
    mode takes it (H x W x C, RGB, row 0 at the top: the same layout as ours)."""
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3 or 0 in image.shape:
        raise ValueError(f"{name} must be a non-empty uint8 (H, W, 3) sRGB image, got {image.dtype} {image.shape}")
    return np.ascontiguousarray(image, dtype=np.float32) / np.float32(255.0)


def flip_map(reference_srgb: np.ndarray, test_srgb: np.ndarray, viewing: ViewingSetup) -> np.ndarray:
    """(H, W) float32 per-pixel LDR-FLIP error in [0, 1] of ``test_srgb`` against
    ``reference_srgb`` (uint8 (H, W, 3) sRGB, what the renderer's PNGs hold).

    The pixels per degree always come from ``viewing`` for the image's width and are
    passed explicitly (never the library's default of 67); both images are sRGB
    (``inputsRGB=True``), no colour map is applied.
    """
    reference = _srgb_unit(reference_srgb, "reference image")
    test = _srgb_unit(test_srgb, "test image")
    if reference.shape != test.shape:
        raise ValueError(f"reference and test images differ in shape: {reference.shape} vs {test.shape}")
    ppd = viewing.pixels_per_degree(reference.shape[1])
    error, _, _ = flip_evaluator.evaluate(
        reference, test, "LDR", inputsRGB=True, applyMagma=False, computeMeanError=False, parameters={"ppd": ppd}
    )
    return np.asarray(error, dtype=np.float32).reshape(reference.shape[:2])
