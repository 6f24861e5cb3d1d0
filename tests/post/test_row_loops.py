"""The post stage's native row loops against numpy references: the tone map's (curve,
8-bit sRGB code, FXAA luma) and FXAA's contrast test, on spans that start and stop
anywhere (chunk remainders, the border columns, one pixel), with non-finite input."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from fxaa_reference import code_luma

from warp_hybrid.parallel import Launcher
from warp_hybrid.post.aa import EDGE_THRESHOLD, EDGE_THRESHOLD_MIN, fxaa_edge_pixels, luma_buffer
from warp_hybrid.post.color import make_srgb8_encoder, srgb_thresholds
from warp_hybrid.post.exposure import Exposure
from warp_hybrid.post.kernels import TONEMAP_KERNELS
from warp_hybrid.post.postprocess import PostProcess
from warp_hybrid.timing import StageTimer

wp.set_module_options({"enable_backward": False})

H, W = 5, 130  # 130 = two 64-pixel chunks and a remainder
SPANS = [(0, W), (0, 1), (1, 2), (3, 67), (64, 128), (W - 1, W), (W - 2, W), (0, W - 1)]


def _aces_f32(x: np.ndarray) -> np.ndarray:
    """Narkowicz's curve in float32, one rounding per operation (as the kernels)."""
    f = np.float32
    c = np.fmax(x, f(0.0))
    with np.errstate(over="ignore", invalid="ignore"):
        num = c * (f(2.51) * c + f(0.03))
        den = c * (f(2.43) * c + f(0.59)) + f(0.14)
        return np.fmin(np.fmax(f(0.0), num / den), f(1.0))


def _codes(tone: np.ndarray) -> np.ndarray:
    """round(255 * srgb_encode(t)) by the code thresholds (NaN -> 0)."""
    t = np.where(np.isnan(tone), np.float32(0.0), tone)
    return np.searchsorted(srgb_thresholds(), t, side="right")


def _hdr(rng: np.random.Generator) -> np.ndarray:
    img = (rng.random((H, W, 3), dtype=np.float32) ** 3 * 6.0).astype(np.float32)
    img[0, 5] = (np.nan, np.inf, -np.inf)
    img[1, 64] = (-1.0, 1e30, 0.0)
    return img


def test_tone_map_rows_match_numpy(device):
    rng = np.random.default_rng(3)
    hdr = _hdr(rng)
    scale = np.float32(1.7)
    tone = _aces_f32(hdr * scale)
    codes = _codes(tone)
    luma = code_luma(codes)
    exposure = Exposure()
    exposure.ev = float(np.log2(scale))
    exposure.scale = float(scale)
    with Launcher(device) as launcher:
        for x0, x1 in SPANS:
            ldr = wp.full((H, W, 3), 7, dtype=wp.uint8, device=device)
            luma_out = luma_buffer(H, W, device)
            spare = luma_out._ref  # (the rows with their spare columns)
            spare.fill_(-1.0)
            inputs = [
                wp.array(hdr, dtype=wp.vec3, device=device),
                wp.array([exposure], dtype=Exposure, device=device),
                make_srgb8_encoder(device),
                ldr,
                luma_out,
                x0,
                x1,
            ]
            launcher.launch_pixels(TONEMAP_KERNELS[("aces", True)], H, W, inputs)
            got, got_luma = ldr.numpy(), luma_out.numpy()
            np.testing.assert_array_equal(got[:, x0:x1], codes[:, x0:x1], err_msg=f"span {x0}-{x1}")
            np.testing.assert_array_equal(got_luma[:, x0:x1], luma[:, x0:x1], err_msg=f"span {x0}-{x1}")
            outside = np.ones(W, bool)
            outside[x0:x1] = False
            assert np.all(got[:, outside] == 7) and np.all(got_luma[:, outside] == -1.0), f"span {x0}-{x1}"
            # the spare columns beside a row hold its edge pixels' luma where the span reaches them
            beside = spare.numpy()
            np.testing.assert_array_equal(beside[:, 0], luma[:, 0] if x0 == 0 else -1.0)
            np.testing.assert_array_equal(beside[:, W + 1], luma[:, W - 1] if x1 == W else -1.0)


@wp.kernel
def _edge_list_kernel(
    img: wp.array3d(dtype=wp.uint8),
    luma: wp.array2d(dtype=float),
    out: wp.array3d(dtype=wp.uint8),
    edges: wp.array2d(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    x0: int,
    x1: int,
):
    y = wp.tid()
    counts[y] = fxaa_edge_pixels(img, luma, out, edges, y, x0, x1)


def _contrast_reference(luma: np.ndarray) -> np.ndarray:
    """FXAA's step 1 in numpy: the range of each pixel and its 4 neighbours (clamped to
    the edge) against max(EDGE_THRESHOLD_MIN, EDGE_THRESHOLD * max)."""
    p = np.pad(luma, 1, mode="edge")
    five = np.stack([p[1:-1, 1:-1], p[:-2, 1:-1], p[2:, 1:-1], p[1:-1, :-2], p[1:-1, 2:]])
    lmax, lmin = five.max(axis=0), five.min(axis=0)
    threshold = np.maximum(np.float32(EDGE_THRESHOLD_MIN), lmax * np.float32(EDGE_THRESHOLD))
    return (lmax - lmin) >= threshold


@pytest.mark.parametrize("height", [40, 1])
def test_fxaa_contrast_test_lists_the_reference_pixels(device, height):
    rng = np.random.default_rng(5)
    # ranges around the threshold, so about half the pixels pass (the border columns'
    # answers depend on their neighbours clamping to the edge)
    luma = (0.3 + 0.12 * rng.random((height, W), dtype=np.float32)).astype(np.float32)
    img = rng.integers(0, 256, (height, W, 3), dtype=np.uint8)
    expected = _contrast_reference(luma)
    assert 0.2 < expected.mean() < 0.8
    for x0, x1 in SPANS:
        out = wp.zeros((height, W, 3), dtype=wp.uint8, device=device)
        edges = wp.full((height, W), -1, dtype=wp.int32, device=device)
        counts = wp.zeros(height, dtype=wp.int32, device=device)
        inputs = [wp.array(img, device=device), wp.array(luma, device=device), out, edges, counts, x0, x1]
        wp.launch(_edge_list_kernel, dim=height, inputs=inputs, device=device)
        listed, n = edges.numpy(), counts.numpy()
        for y in range(height):
            want = x0 + np.flatnonzero(expected[y, x0:x1])
            np.testing.assert_array_equal(listed[y, x0 : x0 + n[y]], want, err_msg=f"row {y}, span {x0}-{x1}")
        copied = out.numpy()
        np.testing.assert_array_equal(copied[:, x0:x1], img[:, x0:x1])
        assert not copied[:, :x0].any() and not copied[:, x1:].any()


def test_post_process_refuses_a_strided_colour_view(device):
    whole = wp.zeros((8, 12), dtype=wp.vec3, device=device)
    with Launcher(device) as launcher, pytest.raises(ValueError, match="contiguous"):
        PostProcess(launcher).process(whole[:, 2:6], 0.0, "aces", True, StageTimer())
