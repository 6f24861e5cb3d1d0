"""The mid-resolution ring's layout: which pixels it traces (the window's, then the lattice
between the window and the outer shape), how many (the annulus's area over step^2), the
blend weights (the outer shape's feather), and the tile counts the controller sizes it by."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_focus_region import inside_mask, reference_weight

from warp_hybrid.adapt import BudgetController, ControllerSettings, TileGrid
from warp_hybrid.errors import RenderSettingsError
from warp_hybrid.focus import FocusRegionBuilder, FocusWindow
from warp_hybrid.focus.ring import RingSpec
from warp_hybrid.focus.ring_builder import RingedFocusBuilder
from warp_hybrid.parallel import Launcher
from warp_hybrid.renderer import RenderSettings
from warp_hybrid.timing import StageTimer

W, H = 200, 150


@pytest.fixture(scope="module")
def launcher(device: str) -> Launcher:
    launcher = Launcher(device, threads=2)
    yield launcher
    launcher.close()


def lattice_mask(step: int) -> np.ndarray:
    ys, xs = np.mgrid[0:H, 0:W]
    return (xs % step == 0) & (ys % step == 0)


CASES = [
    (FocusWindow((0.5, 0.5), 0.05, "circle", 6.0), RingSpec(2.0, 2)),
    (FocusWindow((0.45, 0.55), 0.04, "circle", 4.0), RingSpec(1.5, 4)),
    (FocusWindow((0.5, 0.5), 0.06, "rect", 6.0), RingSpec(2.0, 2)),
    (FocusWindow((0.1, 0.9), 0.1, "circle", 8.0), RingSpec(2.5, 3)),  # the ring cut by the screen
]


@pytest.mark.parametrize(("window", "spec"), CASES, ids=lambda c: repr(c))
def test_the_ring_traces_the_window_then_its_lattice_between_window_and_outer_shape(
    launcher: Launcher, window: FocusWindow, spec: RingSpec
) -> None:
    region = RingedFocusBuilder(launcher, W, H, spec).build_ringed(window, StageTimer())
    plain = FocusRegionBuilder(launcher, W, H).build(window, StageTimer())
    pixels = region.pixels.numpy()[: region.count]
    n = plain.count
    assert region.layout == plain.layout and region.ring is not None
    np.testing.assert_array_equal(pixels[:n], plain.pixels.numpy()[:n])  # the window first, unchanged
    inner, outer = inside_mask(region.layout), inside_mask(region.ring.outer)
    expected = np.flatnonzero(outer & ~inner & lattice_mask(spec.step))
    np.testing.assert_array_equal(pixels[n:], expected)  # then the ring's lattice, row-major
    assert region.ring.count == len(expected) == region.count - n > 0
    assert region.rows == (region.ring.outer.y0, region.ring.outer.y1)


@pytest.mark.parametrize(("window", "spec"), CASES[:3], ids=lambda c: repr(c))
def test_the_ring_traces_the_annulus_area_over_step_squared(
    launcher: Launcher, window: FocusWindow, spec: RingSpec
) -> None:
    """Away from the screen edges the lattice count is the annulus's area / step^2 (to the
    pixels along its two boundaries), and the traced total is the window times
    ``traced_per_window_pixel``."""
    region = RingedFocusBuilder(launcher, W, H, spec).build_ringed(window, StageTimer())
    layout = region.layout
    if layout.shape == "circle":
        area = math.pi * layout.radius**2 * (spec.scale**2 - 1.0)
        boundary = 2.0 * math.pi * layout.radius * (1.0 + spec.scale)
    else:
        area = 4.0 * layout.half_width * layout.half_height * (spec.scale**2 - 1.0)
        boundary = 4.0 * (layout.half_width + layout.half_height) * (1.0 + spec.scale)
    assert abs(region.ring.count - area / spec.step**2) <= boundary / spec.step
    assert region.ring.count == pytest.approx(area / spec.step**2, rel=0.06)
    assert region.count == pytest.approx(layout.count * spec.traced_per_window_pixel, rel=0.06)


@pytest.mark.parametrize(("window", "spec"), CASES, ids=lambda c: repr(c))
def test_the_weights_are_the_outer_shapes_feather(launcher: Launcher, window: FocusWindow, spec: RingSpec) -> None:
    region = RingedFocusBuilder(launcher, W, H, spec).build_ringed(window, StageTimer())
    weight = region.weight.numpy()
    outer = inside_mask(region.ring.outer)
    np.testing.assert_array_equal(weight > 0, outer)  # > 0 over the whole ring, 0 beyond it
    np.testing.assert_allclose(weight[outer], reference_weight(region.ring.outer)[outer], atol=2e-5)
    # The window lies deeper than the feather inside the outer shape: all of it at weight 1.
    assert np.all(weight[inside_mask(region.layout)] == 1.0)


def test_rebuilding_resets_the_rings_weights(launcher: Launcher) -> None:
    """A ringed build then a plain one (the guard's window when it stops before the ring)
    and another ringed one leave exactly each build's own weights."""
    builder = RingedFocusBuilder(launcher, W, H, RingSpec(2.0, 2))
    big = FocusWindow((0.4, 0.5), 0.08, "circle", 6.0)
    small = FocusWindow((0.6, 0.4), 0.02, "rect", 4.0)
    with Launcher(launcher.device, threads=1) as fresh_launcher:
        for window in (big, small, big):
            ringed = builder.build_ringed(window, StageTimer()).weight.numpy()
            fresh = RingedFocusBuilder(fresh_launcher, W, H, RingSpec(2.0, 2)).build_ringed(window, StageTimer())
            np.testing.assert_array_equal(ringed, fresh.weight.numpy())
            plain = builder.build(window, StageTimer()).weight.numpy()
            np.testing.assert_array_equal(
                plain, FocusRegionBuilder(fresh_launcher, W, H).build(window, StageTimer()).weight.numpy()
            )


def test_a_full_screen_or_empty_window_has_no_ring(launcher: Launcher) -> None:
    builder = RingedFocusBuilder(launcher, W, H, RingSpec())
    for window in (FocusWindow((0.5, 0.5), 1.0), FocusWindow((0.5, 0.5), 0.0)):
        region = builder.build_ringed(window, StageTimer())
        assert region.ring is None and region.count == region.layout.count


def test_the_controller_counts_the_ring_per_tile(launcher: Launcher) -> None:
    spec = RingSpec(2.0, 2)
    window = FocusWindow((0.3, 0.6), 0.06, "circle", 6.0)
    region = RingedFocusBuilder(launcher, W, H, spec).build_ringed(window, StageTimer())
    grid = TileGrid(W, H, 32)
    pixels = region.pixels.numpy()[: region.count]
    expected = np.zeros(grid.shape, dtype=np.int64)
    np.add.at(expected, ((pixels // W) // 32, (pixels % W) // 32), 1)
    controller = BudgetController(ControllerSettings(budget_ms=50.0, ring=spec), W, H, "circle", 6.0)
    np.testing.assert_array_equal(controller.tile_coverage(window.gaze, window.fraction), expected)
    plain = BudgetController(ControllerSettings(budget_ms=50.0), W, H, "circle", 6.0)
    assert plain.tile_coverage(window.gaze, window.fraction).sum() == region.layout.count


@pytest.mark.parametrize(
    ("scale", "step"), [(1.0, 2), (0.5, 2), (math.inf, 2), (math.nan, 2), (9.0, 2), (2.0, 1), (2.0, 9), (2.0, 2.5)]
)
def test_bad_ring_sizes_are_refused(scale: float, step: int) -> None:
    with pytest.raises(RenderSettingsError, match="ring"):
        RenderSettings(ring=True, ring_scale=scale, ring_step=step).validate()
    with pytest.raises(RenderSettingsError, match="ring"):
        ControllerSettings(budget_ms=10.0, ring=RingSpec(scale, step)).validate()
