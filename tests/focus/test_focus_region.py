"""Focus region: the traced pixel list, the feathered blend weights, buffer reuse."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.focus import FocusRegion, FocusRegionBuilder, FocusWindow, WindowLayout
from warp_hybrid.parallel import Launcher
from warp_hybrid.timing import StageTimer

W, H = 160, 120


@pytest.fixture(scope="module")
def builder(device: str) -> FocusRegionBuilder:
    """One builder for the module's tests (two launch threads)."""
    launcher = Launcher(device, threads=2)
    yield FocusRegionBuilder(launcher, W, H)
    launcher.close()


def host(region: FocusRegion) -> tuple[np.ndarray, np.ndarray]:
    """The region's valid pixel list and its weight image on the host."""
    return region.pixels.numpy()[: region.count], region.weight.numpy()


def reference_weight(layout: WindowLayout) -> np.ndarray:
    """Float64 smoothstep of the distance to the seam (independent of the kernel):
    circle r - |p - c|, rect the nearest edge that lies inside the screen."""
    px = np.arange(layout.width) + 0.5
    py = (np.arange(layout.height) + 0.5)[:, None]
    if layout.shape == "circle":
        d = layout.radius - np.hypot(px - layout.cx, py - layout.cy)
    else:
        d = np.full((layout.height, layout.width), np.inf)
        x_lo, x_hi = layout.cx - layout.half_width, layout.cx + layout.half_width
        y_lo, y_hi = layout.cy - layout.half_height, layout.cy + layout.half_height
        if x_lo > 0:
            d = np.minimum(d, px - x_lo)
        if x_hi < layout.width:
            d = np.minimum(d, x_hi - px)
        if y_lo > 0:
            d = np.minimum(d, py - y_lo)
        if y_hi < layout.height:
            d = np.minimum(d, y_hi - py)
    if layout.feather_px == 0.0:
        return (d > 0).astype(np.float64)
    t = np.clip(d / layout.feather_px, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def inside_mask(layout: WindowLayout) -> np.ndarray:
    start, stop = layout.row_spans()
    cols = np.arange(layout.width)
    return (cols >= start[:, None]) & (cols < stop[:, None])


CASES = [
    FocusWindow((0.5, 0.5), 0.25, "circle", 8.0),
    FocusWindow((0.5, 0.5), 0.25, "rect", 8.0),
    FocusWindow((0.05, 0.9), 0.1, "circle", 6.0),
    FocusWindow((0.0, 0.0), 0.2, "rect", 10.0),
    FocusWindow((0.7, 0.3), 0.8, "circle", 12.0),  # taller than the screen: cut top and bottom
    FocusWindow((0.3, 0.6), 0.15, "circle", 0.0),
    FocusWindow((0.3, 0.6), 0.15, "rect", 0.0),
]


@pytest.mark.parametrize("window", CASES, ids=lambda w: f"{w.shape}-{w.gaze}-{w.fraction}-f{w.feather_px}")
def test_pixel_list_is_the_window_in_row_major_order(builder: FocusRegionBuilder, window: FocusWindow) -> None:
    region = builder.build(window, StageTimer())
    pixels, weight = host(region)
    mask = inside_mask(region.layout)
    assert region.count == region.layout.count == int(mask.sum()) > 0
    np.testing.assert_array_equal(pixels, np.flatnonzero(mask))  # row-major order
    np.testing.assert_array_equal(np.flatnonzero(weight > 0), pixels)
    assert np.all(weight[~mask] == 0.0)


@pytest.mark.parametrize("window", CASES, ids=lambda w: f"{w.shape}-{w.gaze}-{w.fraction}-f{w.feather_px}")
def test_weight_is_smoothstep_of_the_seam_distance(builder: FocusRegionBuilder, window: FocusWindow) -> None:
    region = builder.build(window, StageTimer())
    _, weight = host(region)
    mask = inside_mask(region.layout)
    expected = reference_weight(region.layout)
    np.testing.assert_allclose(weight[mask], expected[mask], atol=2e-5)
    assert np.all(weight[mask] <= 1.0)
    if window.feather_px == 0.0:
        assert set(np.unique(weight)) == {0.0, 1.0}


def test_weight_is_one_beyond_the_feather_and_rises_monotonically(builder: FocusRegionBuilder) -> None:
    feather = 10.0
    region = builder.build(FocusWindow((0.5, 0.5), 0.3, "circle", feather), StageTimer())
    _, weight = host(region)
    layout = region.layout
    px = np.arange(W) + 0.5
    py = (np.arange(H) + 0.5)[:, None]
    dist = layout.radius - np.hypot(px - layout.cx, py - layout.cy)
    assert np.all(weight[dist >= feather] == 1.0)
    band = (dist > 0) & (dist < feather)
    assert np.all((weight[band] > 0) & (weight[band] < 1))
    order = np.argsort(dist[band], kind="stable")
    assert np.all(np.diff(weight[band][order]) >= 0)
    # Along the centre row, the weight climbs from the boundary to the plateau.
    row = weight[int(layout.cy)]
    left = row[layout.x0 : int(layout.cx)]
    assert left[0] < 0.05 and left[-1] == 1.0 and np.all(np.diff(left) >= 0)


def test_screen_edges_are_not_feathered(builder: FocusRegionBuilder) -> None:
    region = builder.build(FocusWindow((0.0, 0.0), 0.25, "rect", 8.0), StageTimer())
    _, weight = host(region)
    layout = region.layout
    # Flush against the top-left corner: full weight along the screen edges, a band at the inner edges.
    assert weight[0, 0] == 1.0 and weight[0, 30] == 1.0 and weight[30, 0] == 1.0
    assert 0.0 < weight[0, layout.x1 - 1] < 0.05
    assert 0.0 < weight[layout.y1 - 1, 0] < 0.05
    full_rect = builder.build(FocusWindow((0.3, 0.3), 1.0, "rect", 8.0), StageTimer())
    assert np.all(full_rect.weight.numpy() == 1.0)


def test_rebuilding_resets_the_previous_window(builder: FocusRegionBuilder) -> None:
    windows = [
        FocusWindow((0.2, 0.3), 0.3, "circle", 8.0),
        FocusWindow((0.8, 0.7), 0.05, "rect", 4.0),
        FocusWindow((0.5, 0.5), 0.0, "circle", 8.0),
        FocusWindow((0.4, 0.5), 0.5, "circle", 8.0),
    ]
    with Launcher(builder.launcher.device, threads=1) as launcher:
        fresh = FocusRegionBuilder(launcher, W, H)
        for window in windows:
            reused_pixels, reused_weight = host(builder.build(window, StageTimer()))
            fresh_pixels, fresh_weight = host(FocusRegionBuilder(launcher, W, H).build(window, StageTimer()))
            np.testing.assert_array_equal(reused_weight, fresh_weight)
            np.testing.assert_array_equal(reused_pixels, fresh_pixels)
            # Threads do not change the result.
            single_pixels, single_weight = host(fresh.build(window, StageTimer()))
            np.testing.assert_array_equal(single_weight, fresh_weight)
            np.testing.assert_array_equal(single_pixels, fresh_pixels)


def test_empty_window_traces_nothing(builder: FocusRegionBuilder) -> None:
    builder.build(FocusWindow((0.5, 0.5), 0.4), StageTimer())
    region = builder.build(FocusWindow((0.5, 0.5), 0.0), StageTimer())
    assert region.count == 0
    assert not np.any(region.weight.numpy())


@pytest.mark.parametrize("shape", ["circle", "rect"])
def test_traced_pixels_scale_with_the_window_area(builder: FocusRegionBuilder, shape: str) -> None:
    small = builder.build(FocusWindow((0.5, 0.5), 0.1, shape), StageTimer()).count
    large = builder.build(FocusWindow((0.5, 0.5), 0.4, shape), StageTimer()).count
    assert large / small == pytest.approx(4.0, rel=0.03)


def test_full_screen_region(builder: FocusRegionBuilder) -> None:
    full = builder.full_screen()
    builder.build(FocusWindow((0.1, 0.1), 0.2), StageTimer())  # must not touch the full region's buffers
    assert full.count == W * H and full.layout.shape == "full"
    np.testing.assert_array_equal(full.pixels.numpy()[: full.count], np.arange(W * H))
    assert np.all(full.weight.numpy() == 1.0)
    assert builder.full_screen() is full


def test_build_is_timed_as_the_focus_stage(builder: FocusRegionBuilder) -> None:
    timer = StageTimer()
    builder.build(FocusWindow((0.5, 0.5), 0.2), timer)
    assert list(timer.stages_ms) == ["focus"]


def test_bad_builder_size(device: str) -> None:
    with Launcher(device, threads=1) as launcher, pytest.raises(ValueError, match="screen size must be positive"):
        FocusRegionBuilder(launcher, 0, 10)
