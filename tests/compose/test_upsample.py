"""The ring's upsampling: the traced effects on the lattice, interpolated to the ring's other
pixels with the G-buffer as the guide, reproduce a smooth signal (a linear one exactly, a
quadratic one within the bilinear bound), do not bleed across a depth edge or into another
material, and fall back to the raster layer where no sample is usable."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.compose.upsample import RingUpsampler
from warp_hybrid.core.passes import FrameBuffers, FrameContext
from warp_hybrid.focus import FocusRegion, FocusWindow
from warp_hybrid.focus.ring import RingSpec
from warp_hybrid.focus.ring_builder import RingedFocusBuilder
from warp_hybrid.metrics import layout_mask
from warp_hybrid.parallel import Launcher
from warp_hybrid.timing import StageTimer

W, H = 160, 120
WINDOW = FocusWindow((0.5, 0.5), 0.04, "circle", 4.0)
YS, XS = np.mgrid[0:H, 0:W]


@pytest.fixture(scope="module")
def launcher(device: str) -> Launcher:
    launcher = Launcher(device, threads=2)
    yield launcher
    launcher.close()


def plane_gbuffer(buffers: FrameBuffers, depth_step_at: int | None = None, material: np.ndarray | None = None) -> None:
    """A plane facing the camera (normal +z, positions on the pixel grid), every pixel hit;
    right of column ``depth_step_at`` it lies 5 units nearer (a depth edge)."""
    gb = buffers.gbuffer
    device = buffers.device
    z = np.zeros((H, W), np.float32) if depth_step_at is None else np.where(XS > depth_step_at, 5.0, 0.0)
    position = np.stack([XS + 0.5, YS + 0.5, z], axis=-1).astype(np.float32) * 0.01
    normal = np.broadcast_to(np.array([0.0, 0.0, 1.0], np.float32), (H, W, 3)).copy()
    gb.position.assign(wp.array(position, dtype=wp.vec3, device=device))
    gb.normal.assign(wp.array(normal, dtype=wp.vec3, device=device))
    gb.triangle_id.assign(wp.array(np.zeros((H, W), np.int32), dtype=wp.int32, device=device))
    ids = np.zeros((H, W), np.int32) if material is None else material.astype(np.int32)
    gb.material_id.assign(wp.array(ids, dtype=wp.int32, device=device))


def upsample(
    launcher: Launcher, effect: np.ndarray, spec: RingSpec, **gbuffer: object
) -> tuple[np.ndarray, np.ndarray, FocusRegion, np.ndarray]:
    """Trace ``raster + effect`` at the ringed region's listed pixels (NaN elsewhere), run the
    upsampler; return the traced layer after it, the raster layer, the region and its mask of
    traced pixels."""
    device = launcher.device
    buffers = FrameBuffers(W, H, 0, device)
    plane_gbuffer(buffers, **gbuffer)
    region = RingedFocusBuilder(launcher, W, H, spec).build_ringed(WINDOW, StageTimer())
    listed = np.zeros(H * W, bool)
    listed[region.pixels.numpy()[: region.count]] = True
    listed = listed.reshape(H, W)
    rng = np.random.default_rng(3)
    raster = rng.uniform(0.0, 2.0, (H, W, 3)).astype(np.float32)  # full-rate detail the fill must keep
    traced = np.where(listed[..., None], raster + effect[..., None], np.nan).astype(np.float32)
    buffers.raster_color.assign(wp.array(raster, dtype=wp.vec3, device=device))
    buffers.traced_color.assign(wp.array(traced, dtype=wp.vec3, device=device))
    frame = FrameContext(camera=None, timer=StageTimer(), buffers=buffers, region=region)
    RingUpsampler(launcher).execute(frame)
    assert "upsample" in frame.timer.stages_ms
    return buffers.traced_color.numpy(), raster, region, listed


def interior(region: FocusRegion, step: int) -> tuple[np.ndarray, np.ndarray]:
    """The ring's untraced pixels, and those of them whose 2 x 2 lattice pixels were all traced."""
    outer = layout_mask(region.ring.outer)
    ring = outer & ~layout_mask(region.layout)
    untraced = ring & ~((XS % step == 0) & (YS % step == 0))
    x0, y0 = XS // step * step, YS // step * step
    whole = untraced.copy()
    for dx in (0, step):
        for dy in (0, step):
            qx, qy = x0 + dx, y0 + dy
            ok = (qx < W) & (qy < H)
            whole &= ok & outer[np.minimum(qy, H - 1), np.minimum(qx, W - 1)]
    return untraced, whole


@pytest.mark.parametrize("step", [2, 4])
def test_a_linear_signal_is_reproduced_exactly(launcher: Launcher, step: int) -> None:
    effect = (0.3 + 0.02 * XS - 0.015 * YS).astype(np.float32)
    out, raster, region, listed = upsample(launcher, effect, RingSpec(2.5, step))
    untraced, whole = interior(region, step)
    assert whole.sum() > 0.8 * untraced.sum() > 1000
    got = out[..., 0] - raster[..., 0]
    np.testing.assert_allclose(got[whole], effect[whole], atol=2e-5)
    # Near the outer edge and the screen the samples are renormalised: still within the signal's range.
    assert np.isfinite(out[untraced]).all()
    assert got[untraced].min() >= effect[listed].min() - 1e-4 and got[untraced].max() <= effect[listed].max() + 1e-4
    # The traced pixels keep their values; nothing outside the ring is written.
    np.testing.assert_array_equal(out[listed], (raster + effect[..., None])[listed])
    assert np.isnan(out[~layout_mask(region.ring.outer)]).all()


def test_a_quadratic_signal_is_within_the_bilinear_bound(launcher: Launcher) -> None:
    """Bilinear interpolation on a lattice of spacing s errs by at most s^2 / 8 (|f_xx| + |f_yy|)."""
    step, k = 2, 0.004
    effect = (k * ((XS - 80.0) ** 2 + (YS - 60.0) ** 2)).astype(np.float32)
    out, raster, region, _ = upsample(launcher, effect, RingSpec(2.5, step))
    _, whole = interior(region, step)
    error = np.abs(out[..., 1] - raster[..., 1] - effect)[whole]
    bound = step**2 / 8.0 * (2 * k + 2 * k)
    assert error.max() <= bound + 1e-4
    assert error.max() > 0.5 * bound  # the bound is what the filter does, not a loose one


def test_no_bleeding_across_a_depth_edge(launcher: Launcher) -> None:
    edge = 75  # columns <= 75 lie on the far plane, the rest 5 units nearer
    effect = np.where(XS > edge, 10.0, 1.0).astype(np.float32)
    out, raster, region, _ = upsample(launcher, effect, RingSpec(2.5, 2), depth_step_at=edge)
    untraced, _ = interior(region, 2)
    got = out[..., 2] - raster[..., 2]
    assert (untraced & (XS == edge)).any() and (untraced & (XS == edge + 1)).any()
    np.testing.assert_allclose(got[untraced], effect[untraced], atol=1e-4)


def test_other_materials_are_rejected_and_no_usable_sample_falls_back_to_raster(launcher: Launcher) -> None:
    """A pixel whose 2 x 2 lattice pixels are all another material takes the wider ring of
    samples (their tent mean of a linear signal is exact); a pixel of a material no lattice
    pixel near it has gets the raster layer."""
    step = 2
    effect = (1.0 + 0.01 * XS + 0.02 * YS).astype(np.float32)
    material = np.zeros((H, W), np.int32)
    wide = (53, 61)  # (x, y): its four nearest lattice pixels become material 1
    for dx in (-1, 1):
        for dy in (-1, 1):
            material[wide[1] + dy, wide[0] + dx] = 1
    lonely = (61, 41)  # a material of its own
    material[lonely[1], lonely[0]] = 2
    out, raster, region, _ = upsample(launcher, effect, RingSpec(2.5, step), material=material)
    untraced, _ = interior(region, step)
    assert untraced[wide[1], wide[0]] and untraced[lonely[1], lonely[0]]
    got = out[..., 0] - raster[..., 0]
    assert got[wide[1], wide[0]] == pytest.approx(effect[wide[1], wide[0]], abs=2e-5)
    np.testing.assert_array_equal(out[lonely[1], lonely[0]], raster[lonely[1], lonely[0]])
