"""The error report: identical frames, a hand-made window mask, a focus window's mask."""

from __future__ import annotations

import math

import numpy as np
import pytest

from warp_hybrid.focus import FocusWindow
from warp_hybrid.metrics import ErrorReport, ViewingSetup, evaluate, flip_map, layout_mask, psnr


def _frames(h: int = 24, w: int = 32):
    """A reference (sRGB, linear) and a test frame differing in the left half."""
    y, x = np.mgrid[0:h, 0:w]
    srgb = np.stack([x * 8 % 256, y * 10 % 256, np.full((h, w), 90)], axis=-1).astype(np.uint8)
    linear = (srgb.astype(np.float64) / 255.0) ** 2.2
    test_srgb = srgb.copy()
    test_srgb[:, : w // 2] //= 2
    test_linear = linear.copy()
    test_linear[:, : w // 2] *= 0.25
    return srgb, test_srgb, linear, test_linear


def test_identical_frames_score_zero():
    srgb, _, linear, _ = _frames()
    mask = np.zeros(srgb.shape[:2], bool)
    mask[4:10, 4:12] = True
    report = evaluate(srgb, srgb.copy(), linear, linear.copy(), (0.3, 0.4), mask)
    assert report == ErrorReport(0.0, 0.0, 0.0, 0.0, math.inf)


def test_inside_outside_on_a_hand_made_mask():
    srgb, test_srgb, linear, test_linear = _frames()
    h, w = srgb.shape[:2]
    viewing = ViewingSetup(distance_m=2.0)
    mask = np.zeros((h, w), bool)
    mask[:, w // 2 :] = True  # the right half, where the frames agree
    report = evaluate(srgb, test_srgb, linear, test_linear, (0.25, 0.5), mask, viewing)
    error = flip_map(srgb, test_srgb, viewing)
    assert report.flip_mean == pytest.approx(error.mean(dtype=np.float64))
    assert report.flip_inside == pytest.approx(error[:, w // 2 :].mean(dtype=np.float64))
    assert report.flip_outside == pytest.approx(error[:, : w // 2].mean(dtype=np.float64))
    assert report.flip_outside > report.flip_inside
    assert report.psnr == pytest.approx(psnr(linear, test_linear))
    # Gaze on the differing half weighs its error more than the plain mean does.
    assert report.flip_foveated > report.flip_mean


def test_empty_regions_are_nan():
    srgb, test_srgb, linear, test_linear = _frames()
    no_window = evaluate(srgb, test_srgb, linear, test_linear, (0.5, 0.5))
    assert math.isnan(no_window.flip_inside)
    assert no_window.flip_outside == pytest.approx(no_window.flip_mean)
    full = evaluate(srgb, test_srgb, linear, test_linear, (0.5, 0.5), np.ones(srgb.shape[:2], bool))
    assert math.isnan(full.flip_outside)
    assert full.flip_inside == pytest.approx(full.flip_mean)


def test_mask_from_a_focus_window():
    layout = FocusWindow((0.3, 0.6), 0.25).layout(32, 24)
    mask = layout_mask(layout)
    assert mask.shape == (24, 32)
    assert int(mask.sum()) == layout.count
    start, stop = layout.row_spans()
    for j in range(24):
        assert np.array_equal(np.flatnonzero(mask[j]), np.arange(start[j], stop[j]))


def test_mismatched_inputs_are_refused():
    srgb, test_srgb, linear, test_linear = _frames()
    with pytest.raises(ValueError, match="mask"):
        evaluate(srgb, test_srgb, linear, test_linear, (0.5, 0.5), np.zeros((3, 3), bool))
    with pytest.raises(ValueError, match="linear"):
        evaluate(srgb, test_srgb, linear[:-1], test_linear[:-1], (0.5, 0.5))
