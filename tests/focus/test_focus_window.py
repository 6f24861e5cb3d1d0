"""Focus window layout: sizes, pixel counts, clamping at the screen edges, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from warp_hybrid.focus import FocusWindow, WindowLayout


def brute_force_mask(layout: WindowLayout) -> np.ndarray:
    """(H, W) pixels whose centre lies strictly inside the layout's shape."""
    px = np.arange(layout.width) + 0.5
    py = (np.arange(layout.height) + 0.5)[:, None]
    dx, dy = px - layout.cx, py - layout.cy
    if layout.shape == "circle":
        return dx * dx + dy * dy < layout.radius**2
    if layout.shape == "rect":
        return (np.abs(dx) < layout.half_width) & (np.abs(dy) < layout.half_height)
    return np.ones((layout.height, layout.width), dtype=bool)


def spans_mask(layout: WindowLayout) -> np.ndarray:
    """(H, W) mask of the layout's per-row column runs."""
    start, stop = layout.row_spans()
    cols = np.arange(layout.width)
    return (cols >= start[:, None]) & (cols < stop[:, None])


@pytest.mark.parametrize("fraction", [0.05, 0.1, 0.25, 0.5])
def test_centred_circle_extent_and_count(fraction: float) -> None:
    w, h = 640, 480
    layout = FocusWindow((0.5, 0.5), fraction, "circle").layout(w, h)
    assert layout.shape == "circle"
    assert layout.radius == pytest.approx(math.sqrt(fraction * w * h / math.pi), rel=1e-12)
    assert (layout.cx, layout.cy) == (320.0, 240.0)
    assert layout.count == pytest.approx(fraction * w * h, rel=0.01)
    # The widest row/column of pixel centres is 0.5 px off the integer centre.
    half = math.sqrt(layout.radius**2 - 0.25)
    assert (layout.x0, layout.x1, layout.y0, layout.y1) == (
        math.floor(320 - half - 0.5) + 1,
        math.ceil(320 + half - 0.5),
        math.floor(240 - half - 0.5) + 1,
        math.ceil(240 + half - 0.5),
    )


@pytest.mark.parametrize("fraction", [0.05, 0.1, 0.25, 0.5, 0.9])
def test_centred_rect_extent_and_count(fraction: float) -> None:
    w, h = 1280, 960
    layout = FocusWindow((0.5, 0.5), fraction, "rect").layout(w, h)
    assert layout.shape == "rect"
    assert layout.half_width == pytest.approx(math.sqrt(fraction) * w / 2, rel=1e-12)
    assert layout.half_height == pytest.approx(math.sqrt(fraction) * h / 2, rel=1e-12)
    assert layout.count == pytest.approx(fraction * w * h, rel=0.01)
    assert layout.count == (layout.x1 - layout.x0) * (layout.y1 - layout.y0)


@pytest.mark.parametrize("shape", ["circle", "rect"])
@pytest.mark.parametrize("gaze", [(0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.13, 0.71)])
@pytest.mark.parametrize("fraction", [0.03, 0.3, 0.8])
def test_pixels_are_those_with_centre_inside(shape: str, gaze: tuple[float, float], fraction: float) -> None:
    layout = FocusWindow(gaze, fraction, shape).layout(160, 120)
    mask = brute_force_mask(layout)
    np.testing.assert_array_equal(spans_mask(layout), mask)
    assert layout.count == int(mask.sum())
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    assert (layout.x0, layout.x1, layout.y0, layout.y1) == (cols[0], cols[-1] + 1, rows[0], rows[-1] + 1)


@pytest.mark.parametrize("shape", ["circle", "rect"])
def test_corner_clamping_keeps_the_size(shape: str) -> None:
    w, h, fraction = 640, 480, 0.2
    centred = FocusWindow((0.5, 0.5), fraction, shape).layout(w, h)
    hw, hh = centred.half_width, centred.half_height
    expected_centres = {
        (0.0, 0.0): (hw, hh),
        (1.0, 0.0): (w - hw, hh),
        (0.0, 1.0): (hw, h - hh),
        (1.0, 1.0): (w - hw, h - hh),
    }
    for gaze, (cx, cy) in expected_centres.items():
        layout = FocusWindow(gaze, fraction, shape).layout(w, h)
        assert (layout.half_width, layout.half_height) == (hw, hh)
        assert (layout.cx, layout.cy) == pytest.approx((cx, cy), abs=1e-9)
        # Same size, shifted by a sub-pixel amount relative to the pixel lattice: the
        # count changes by at most one row and one column of edge pixels.
        assert abs(layout.count - centred.count) <= (centred.x1 - centred.x0) + (centred.y1 - centred.y0)
        assert layout.count == pytest.approx(fraction * w * h, rel=0.01)
        assert layout.x0 == 0 if gaze[0] == 0.0 else layout.x1 == w
        assert layout.y0 == 0 if gaze[1] == 0.0 else layout.y1 == h


def test_window_that_fits_is_not_moved() -> None:
    layout = FocusWindow((0.3, 0.6), 0.1, "circle").layout(640, 480)
    assert (layout.cx, layout.cy) == pytest.approx((192.0, 288.0))


def test_gaze_outside_the_screen_is_clamped_first() -> None:
    for shape in ("circle", "rect"):
        far = FocusWindow((-3.0, 7.5), 0.1, shape).layout(640, 480)
        corner = FocusWindow((0.0, 1.0), 0.1, shape).layout(640, 480)
        assert far == corner
        inf = FocusWindow((math.inf, -math.inf), 0.1, shape).layout(640, 480)
        assert inf == FocusWindow((1.0, 0.0), 0.1, shape).layout(640, 480)


def _circle_strip_area(r: float, half: float) -> float:
    """Area of a disc of radius r cut by the strip |y| < half (half < r)."""
    return 2.0 * (half * math.sqrt(r * r - half * half) + r * r * math.asin(half / r))


@pytest.mark.parametrize(("w", "h"), [(640, 480), (480, 640)])
def test_oversize_circle_is_centred_and_cut_by_the_screen(w: int, h: int) -> None:
    fraction = 0.8
    r = math.sqrt(fraction * w * h / math.pi)
    short = min(w, h)
    assert 2 * r > short and 2 * r < max(w, h)
    layout = FocusWindow((0.0, 0.0), fraction, "circle").layout(w, h)
    assert layout.radius == pytest.approx(r)
    if h < w:
        assert (layout.cx, layout.cy) == pytest.approx((r, h / 2))
        assert (layout.y0, layout.y1) == (0, h)
    else:
        assert (layout.cx, layout.cy) == pytest.approx((w / 2, r))
        assert (layout.x0, layout.x1) == (0, w)
    assert layout.count < fraction * w * h
    assert layout.count == pytest.approx(_circle_strip_area(r, short / 2), rel=0.002)


@pytest.mark.parametrize("shape", ["circle", "rect"])
def test_zero_and_full_fraction(shape: str) -> None:
    empty = FocusWindow((0.2, 0.9), 0.0, shape).layout(64, 48)
    assert empty.count == 0
    assert (empty.x0, empty.x1, empty.y0, empty.y1) == (0, 0, 0, 0)
    full = FocusWindow((0.2, 0.9), 1.0, shape).layout(64, 48)
    assert full.shape == "full"
    assert full.count == 64 * 48
    assert (full.x0, full.x1, full.y0, full.y1) == (0, 64, 0, 48)
    assert full.covered_fraction == 1.0


def test_rect_seams_exclude_screen_edges() -> None:
    assert FocusWindow((0.5, 0.5), 0.25, "rect").layout(64, 48).seam_edges == (True, True, True, True)
    assert FocusWindow((0.0, 1.0), 0.25, "rect").layout(64, 48).seam_edges == (False, True, True, False)
    assert FocusWindow((1.0, 0.0), 0.25, "rect").layout(64, 48).seam_edges == (True, False, False, True)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"gaze": (0.5, 0.5), "fraction": -0.1}, "fraction must be in \\[0, 1\\]"),
        ({"gaze": (0.5, 0.5), "fraction": 1.5}, "fraction must be in \\[0, 1\\]"),
        ({"gaze": (0.5, 0.5), "fraction": math.nan}, "fraction must be in \\[0, 1\\]"),
        ({"gaze": (math.nan, 0.5), "fraction": 0.2}, "gaze must not be NaN"),
        ({"gaze": (0.5,), "fraction": 0.2}, "gaze must be two numbers"),
        ({"gaze": (0.5, 0.5), "fraction": 0.2, "shape": "hexagon"}, "shape must be one of circle, rect"),
        ({"gaze": (0.5, 0.5), "fraction": 0.2, "feather_px": -1.0}, "feather must be a finite number of pixels >= 0"),
        ({"gaze": (0.5, 0.5), "fraction": 0.2, "feather_px": math.inf}, "feather must be a finite number"),
    ],
)
def test_bad_window_raises_clear_error(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        FocusWindow(**kwargs)


def test_bad_screen_size_raises() -> None:
    with pytest.raises(ValueError, match="screen size must be positive"):
        FocusWindow((0.5, 0.5), 0.2).layout(0, 48)
