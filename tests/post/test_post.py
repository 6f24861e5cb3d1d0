"""Exposure and the whole output stage (tone mapping + sRGB + FXAA)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from exposure_reference import auto_exposure_ev, log_average_luminance
from fxaa_reference import fxaa

from warp_hybrid.parallel import Launcher
from warp_hybrid.post.color import srgb_decode, srgb_encode
from warp_hybrid.post.postprocess import PostProcess
from warp_hybrid.timing import StageTimer


def _run(device, image: np.ndarray, ev=0.0, tonemap="none", aa=False, mask=None, threads=None):
    color = wp.array(np.ascontiguousarray(image, np.float32), dtype=wp.vec3, device=device)
    timer = StageTimer()
    with Launcher(device, threads=threads) as launcher:
        post = PostProcess(launcher)
        out = post.process(color, ev, tonemap, aa, timer, hit_mask=mask).numpy()
    return out, post.last_exposure_ev, timer


def test_auto_exposure_maps_log_average_to_key():
    grey = np.full((20, 30, 3), 0.05, np.float32)
    ev = auto_exposure_ev(grey)
    assert 0.05 * 2.0**ev == pytest.approx(0.18, rel=3e-3)
    # log-average, not mean: two halves at 0.02 and 0.5 average to sqrt(0.02 * 0.5) = 0.1
    split = np.full((20, 30, 3), 0.02, np.float32)
    split[:, 15:] = 0.5
    assert log_average_luminance(split) == pytest.approx(0.1, rel=3e-3)
    # only hit pixels count; black background is ignored by the mask
    mask = np.zeros((20, 30), bool)
    mask[5:15, 5:25] = True
    scene = np.repeat(np.where(mask[..., None], 0.4, 0.0), 3, axis=2).astype(np.float32)
    assert 0.4 * 2.0 ** auto_exposure_ev(scene, mask) == pytest.approx(0.18, rel=1e-3)
    assert auto_exposure_ev(np.zeros((4, 4, 3), np.float32)) == 0.0


def test_exposure_tonemap_and_encode(device):
    x = np.linspace(0.0, 0.45, 48, dtype=np.float32)
    image = np.repeat(np.repeat(x[None, :, None], 8, axis=0), 3, axis=2)
    out, ev, timer = _run(device, image, ev=1.0, tonemap="none")
    assert out.dtype == np.uint8 and out.shape == (8, 48, 3)
    expected = np.round(srgb_encode(np.clip(2.0 * x, 0.0, 1.0)) * 255.0).astype(np.uint8)
    np.testing.assert_array_equal(out[3, :, 1], expected)
    assert ev == 1.0 and set(timer.stages_ms) == {"tonemap"}
    auto, auto_ev, _ = _run(device, np.full((8, 8, 3), 0.05, np.float32), ev=None)
    assert auto_ev == pytest.approx(math.log2(0.18 / 0.0501), rel=1e-6)
    assert srgb_decode(auto[0, 0])[0] == pytest.approx(0.18, rel=0.02)
    aces, _, _ = _run(device, image, ev=0.0, tonemap="aces")
    assert np.all(np.diff(aces[0, :, 0].astype(int)) >= 0) and aces[0, 0, 0] == 0
    with pytest.raises(ValueError, match="tone mapping"):
        _run(device, image, tonemap="filmic")


def test_auto_exposure_on_the_device_takes_every_mask_form(device):
    rng = np.random.default_rng(3)
    image = rng.uniform(0.0, 4.0, size=(12, 20, 3)).astype(np.float32)
    image[0, 0] = np.inf  # non-finite pixels never count
    hit = rng.random((12, 20)) > 0.4
    ids = np.where(hit, 7, -1).astype(np.int32)
    expected = auto_exposure_ev(image, hit)
    color = wp.array(image, dtype=wp.vec3, device=device)
    with Launcher(device, threads=2) as launcher:
        post = PostProcess(launcher)
        for mask in (hit, wp.array(hit, dtype=wp.bool, device=device), wp.array(ids, dtype=wp.int32, device=device)):
            post.auto_exposure(color, mask)
            assert post.last_exposure_ev == pytest.approx(expected, abs=1e-6)
        post.auto_exposure(color, None)
        assert post.last_exposure_ev == pytest.approx(auto_exposure_ev(image), abs=1e-6)
        with pytest.raises(ValueError, match="hit_mask"):
            post.auto_exposure(color, hit[:, :10])
        with pytest.raises(ValueError, match="hit_mask"):
            post.auto_exposure(color, wp.zeros((12, 20), dtype=float, device=device))
        with pytest.raises(ValueError, match="contiguous"):  # (the sums read whole rows)
            post.auto_exposure(color[:, 1:], None)


def _luma(img: np.ndarray) -> np.ndarray:
    return img.astype(np.float64) @ [0.299, 0.587, 0.114]


def test_fxaa_leaves_flat_images_alone(device):
    flat = np.full((24, 32, 3), 0.3, np.float32)
    out, _, timer = _run(device, flat, aa=True)
    ref, _, _ = _run(device, flat, aa=False)
    np.testing.assert_array_equal(out, ref)
    assert "aa" in timer.stages_ms
    # low-contrast noise stays below the edge threshold
    noise = (0.3 + 0.01 * np.random.default_rng(0).random((24, 32, 1))).repeat(3, axis=2).astype(np.float32)
    np.testing.assert_array_equal(_run(device, noise, aa=True)[0], _run(device, noise, aa=False)[0])


def test_fxaa_softens_a_hard_diagonal_edge(device):
    h, w = 32, 32
    rows, cols = np.mgrid[0:h, 0:w]
    edge = (cols > 0.6 * rows + 5).astype(np.float32)
    image = np.repeat(edge[..., None], 3, axis=2)
    aliased, _, _ = _run(device, image, aa=False)
    smooth, _, _ = _run(device, image, aa=True)
    assert set(np.unique(aliased)) == {0, 255}
    between = (smooth[..., 0] > 10) & (smooth[..., 0] < 245)
    near_edge = np.abs(cols - (0.6 * rows + 5)) < 2.0
    assert between.sum() >= h  # about one blended pixel per row
    assert np.all(near_edge[between])  # and only next to the edge
    far = np.abs(cols - (0.6 * rows + 5)) > 3.0
    np.testing.assert_array_equal(smooth[far], aliased[far])


@pytest.mark.parametrize("threads", [1, 2])
def test_fxaa_is_the_reference_bit_for_bit(device, threads):
    """FXAA on images with every kind of edge (random speckle, slanted stripes, blocks of
    colour, a 1-px border row and column) is the numpy reference's, code for code: the
    orientation, both searches (to their full length on long edges), the sub-pixel
    estimate and the final bilinear tap."""
    rng = np.random.default_rng(17)
    rows, cols = np.mgrid[0:37, 0:71]
    images = [
        (rng.random((37, 71, 3)) ** 3).astype(np.float32),
        np.where(((cols * 0.23 + rows) % 11) < 5.5, 0.9, 0.02)[..., None] * np.float32([1.0, 0.6, 0.3]),
        np.kron(rng.random((5, 9, 3)), np.ones((8, 8, 1)))[:37, :71],
        (rng.random((1, 70, 3)) > 0.5).astype(np.float32),
        (rng.random((40, 1, 3)) > 0.5).astype(np.float32),
    ]
    for image in images:
        plain, _, _ = _run(device, image, aa=False)
        smooth, _, _ = _run(device, image, aa=True, threads=threads)
        want = fxaa(plain)
        assert (want != plain).any() or min(image.shape[:2]) == 1
        if device == "cpu":
            np.testing.assert_array_equal(smooth, want)
        else:  # CUDA's arithmetic may differ in the last bit: at most one code, rarely
            assert np.abs(smooth.astype(int) - want).max() <= 1


def test_fxaa_keeps_a_thin_line(device):
    image = np.zeros((24, 32, 3), np.float32)
    image[:, 15] = 1.0
    line, _, _ = _run(device, image, aa=True, threads=2)
    ref, _, _ = _run(device, image, aa=False)
    before = _luma(ref).sum(axis=1)
    after = _luma(line).sum(axis=1)
    # sub-pixel filtering spreads and dims a 1-px line; with SUBPIX = 0.5 it keeps
    # 75-100% of its energy per row (in encoded values, FXAA's domain)
    assert np.all(after >= 0.75 * before) and np.all(after <= before)
    assert np.all(line[:, 15, 0] >= 170)  # and stays bright where it was
    assert np.all(line[:, :13] == 0) and np.all(line[:, 18:] == 0)


def test_one_post_process_serves_several_sizes(device):
    with Launcher(device) as launcher:
        post = PostProcess(launcher)
        for h, w in ((8, 12), (16, 10), (8, 12)):
            color = wp.array(np.full((h, w, 3), 0.5, np.float32), dtype=wp.vec3, device=device)
            out = post.process(color, 0.0, "none", True, StageTimer()).numpy()
            assert out.shape == (h, w, 3)
            np.testing.assert_array_equal(out, round(float(srgb_encode(np.array([0.5]))[0]) * 255.0))
