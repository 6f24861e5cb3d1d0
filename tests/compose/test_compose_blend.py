"""Composition: raster outside, traced inside, an exact lerp in the feather band."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.compose import Compositor
from warp_hybrid.focus import FocusRegionBuilder, FocusWindow
from warp_hybrid.parallel import Launcher
from warp_hybrid.timing import StageTimer

H, W = 48, 64


@pytest.fixture(scope="module")
def launcher(device: str) -> Launcher:
    launcher = Launcher(device, threads=2)
    yield launcher
    launcher.close()


def _images(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random raster/traced colours and a weight with zeros, ones and a band."""
    rng = np.random.default_rng(seed)
    raster = rng.uniform(0.0, 4.0, (H, W, 3)).astype(np.float32)
    traced = rng.uniform(0.0, 4.0, (H, W, 3)).astype(np.float32)
    weight = rng.uniform(0.0, 1.0, (H, W)).astype(np.float32)
    weight[:, :16] = 0.0
    weight[:, 48:] = 1.0
    traced[:, :8] = np.nan  # never traced: must not leak through a zero weight
    return raster, traced, weight


def _expected(raster: np.ndarray, traced: np.ndarray, weight: np.ndarray) -> np.ndarray:
    w = weight[..., None]
    lerp = raster + w * (traced - raster)
    return np.where(w <= 0, raster, np.where(w >= 1, traced, lerp))


def _device(array: np.ndarray, device: wp.context.Device, dtype: type) -> wp.array:
    return wp.array(array, dtype=dtype, device=device)


def test_blend_selects_the_ends_and_lerps_the_band(launcher: Launcher) -> None:
    raster, traced, weight = _images(1)
    out = wp.zeros((H, W), dtype=wp.vec3, device=launcher.device)
    timer = StageTimer()
    Compositor(launcher).blend(
        _device(raster, launcher.device, wp.vec3),
        _device(traced, launcher.device, wp.vec3),
        _device(weight, launcher.device, wp.float32),
        out,
        timer,
    )
    result = out.numpy()
    np.testing.assert_array_equal(result[:, :16], raster[:, :16])
    np.testing.assert_array_equal(result[:, 48:], traced[:, 48:])
    np.testing.assert_allclose(result[:, 16:48], _expected(raster, traced, weight)[:, 16:48], rtol=1e-6, atol=1e-6)
    assert list(timer.stages_ms) == ["compose"]


def test_blend_in_place(launcher: Launcher) -> None:
    raster, traced, weight = _images(2)
    image = _device(raster, launcher.device, wp.vec3)
    traced_d = _device(traced, launcher.device, wp.vec3)
    Compositor(launcher).blend(image, traced_d, _device(weight, launcher.device, wp.float32), image, StageTimer())
    result = image.numpy()
    np.testing.assert_array_equal(result[:, :16], raster[:, :16])
    np.testing.assert_array_equal(result[:, 48:], traced[:, 48:])
    np.testing.assert_allclose(result, _expected(raster, traced, weight), rtol=1e-6, atol=1e-6)


def test_focus_region_composition(launcher: Launcher) -> None:
    """Raster outside the window, traced where the weight is 1, the weight's lerp in the band."""
    region = FocusRegionBuilder(launcher, W, H).build(FocusWindow((0.4, 0.6), 0.3, "circle", 6.0), StageTimer())
    raster = np.full((H, W, 3), 0.25, np.float32)
    traced = np.full((H, W, 3), 2.0, np.float32)
    out = wp.empty((H, W), dtype=wp.vec3, device=launcher.device)
    raster_d, traced_d = _device(raster, launcher.device, wp.vec3), _device(traced, launcher.device, wp.vec3)
    Compositor(launcher).blend(raster_d, traced_d, region.weight, out, StageTimer())
    result = out.numpy()[..., 0]
    weight = region.weight.numpy()
    assert np.all(result[weight == 0] == 0.25)
    assert np.all(result[weight == 1] == 2.0)
    band = (weight > 0) & (weight < 1)
    assert band.sum() > 50
    np.testing.assert_allclose(result[band], 0.25 + weight[band] * 1.75, rtol=1e-6)


def test_blending_only_the_window_rows_gives_the_whole_blend(launcher: Launcher) -> None:
    """Restricted to the window's bounding rows, the blend is bit-identical to blending
    every row: the rows outside are the raster layer copied, whatever ``out`` held and
    whatever (NaN) the traced layer holds there."""
    region = FocusRegionBuilder(launcher, W, H).build(FocusWindow((0.4, 0.6), 0.2, "circle", 6.0), StageTimer())
    layout = region.layout
    assert 0 < layout.y0 < layout.y1 < H  # rows on both sides are skipped
    raster, traced, _ = _images(3)
    traced[: layout.y0] = np.nan
    traced[layout.y1 :] = np.nan
    raster_d, traced_d = _device(raster, launcher.device, wp.vec3), _device(traced, launcher.device, wp.vec3)
    whole = wp.empty((H, W), dtype=wp.vec3, device=launcher.device)
    rows = wp.array(np.full((H, W, 3), 7.0, np.float32), dtype=wp.vec3, device=launcher.device)
    Compositor(launcher).blend(raster_d, traced_d, region.weight, whole, StageTimer())
    Compositor(launcher).blend(raster_d, traced_d, region.weight, rows, StageTimer(), (layout.y0, layout.y1))
    np.testing.assert_array_equal(rows.numpy(), whole.numpy())
    np.testing.assert_array_equal(rows.numpy()[: layout.y0], raster[: layout.y0])


def test_blend_rejects_mismatched_shapes(launcher: Launcher) -> None:
    image = wp.zeros((H, W), dtype=wp.vec3, device=launcher.device)
    small = wp.zeros((H, W - 1), dtype=wp.float32, device=launcher.device)
    with pytest.raises(ValueError, match=r"weight has shape \(48, 63\), expected \(48, 64\)"):
        Compositor(launcher).blend(image, image, small, image, StageTimer())
