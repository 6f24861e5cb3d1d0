"""Automatic exposure on the device: numpy's summation order, the host rules bit for
bit (on the CPU), and no readback inside a frame."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from exposure_reference import ev_from_log_sum

from warp_hybrid.core.native_rows import LAMBDA_HEADER_CPP
from warp_hybrid.parallel import Launcher
from warp_hybrid.post.exposure import EV_LIMIT, LOG_FLOAT_CPP, pairwise_sum
from warp_hybrid.post.postprocess import PostProcess

wp.set_module_options({"enable_backward": False})


@wp.func_native(LAMBDA_HEADER_CPP + LOG_FLOAT_CPP + "return wh_log_float(x);")
def _log_float(x: float) -> wp.float64:
    """``wh_log_float(x)``."""
    ...


@wp.kernel
def _log_float_kernel(x: wp.array(dtype=float), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = _log_float(x[i])


def test_metered_log_is_the_correctly_rounded_logf(device):
    """The metering's log (``wh_log_float``) is within 5e-16 of the float64 log, and
    rounded to float32 it is the correctly rounded log of every input: random positive
    normal floats of every binade, the metered range's floor (``LOG_DELTA``), the edges of
    the mantissa's range ([sqrt(1/2), sqrt(2)), where the exponent steps) and of float32,
    and the floats next to 1."""
    rng = np.random.default_rng(3)
    smallest, largest = np.finfo(np.float32).tiny, np.finfo(np.float32).max
    bits = rng.integers(np.float32(smallest).view(np.uint32), np.float32(largest).view(np.uint32), 300_000)
    specials = np.array([smallest, largest, 1e-4, 1.0, 2.0, 0.5], np.float32)
    centres = np.array([np.sqrt(0.5), np.sqrt(2.0), 1.0, 1e-4], np.float32).view(np.uint32).astype(np.int64)
    neighbours = (centres[:, None] + np.arange(-3, 4)).ravel()
    x = np.concatenate(
        [bits.astype(np.uint32).view(np.float32), specials, neighbours.astype(np.uint32).view(np.float32)]
    )
    out = wp.zeros(len(x), dtype=wp.float64, device=device)
    wp.launch(_log_float_kernel, dim=len(x), inputs=[wp.array(x, dtype=float, device=device), out], device=device)
    got = out.numpy()
    exact = np.array([math.log(v) for v in x.astype(np.float64)])  # (the C library's float64 log)
    np.testing.assert_allclose(got, exact, rtol=5e-16, atol=0.0)
    np.testing.assert_array_equal(got.astype(np.float32), exact.astype(np.float32))


@wp.kernel
def _pairwise_sum_kernel(values: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    out[0] = pairwise_sum(values)


def test_pairwise_sum_is_numpys_sum(device):
    rng = np.random.default_rng(5)
    out = wp.zeros(1, dtype=wp.float64, device=device)
    # below 8, one block, the 8-multiple edges, the recursive halves, a large array
    for n in (0, 1, 7, 8, 9, 15, 16, 127, 128, 129, 136, 255, 256, 257, 1000, 4097, 100_003):
        values = rng.normal(0.0, 1e3, n) * np.exp(rng.normal(0.0, 3.0, n))
        wp.launch(_pairwise_sum_kernel, dim=1, inputs=[wp.array(values, dtype=wp.float64, device=device), out])
        assert out.numpy()[0] == values.sum(), n  # the same float64 additions in the same order


def _hdr(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    image = np.exp(rng.normal(-1.0, 2.0, (h, w, 1))) * rng.uniform(0.2, 1.0, (h, w, 3))
    image[rng.random((h, w)) < 0.2] = 0.0
    return image.astype(np.float32)


def test_device_exposure_is_the_host_rule(device):
    """The EV computed on the device equals ``ev_from_log_sum`` of the same per-row
    sums (bit for bit on the CPU; CUDA's exp/log2 may differ in the last bits), and
    the scale is ``float32(2**ev)``."""
    rng = np.random.default_rng(11)
    exact = not wp.get_device(device).is_cuda
    with Launcher(device, threads=2) as launcher:
        post = PostProcess(launcher)
        for h, w in ((1, 1), (3, 40), (9, 17), (130, 24), (300, 7)):
            post.auto_exposure(wp.array(_hdr(rng, h, w), dtype=wp.vec3, device=device), None)
            rows = post._buffers["row_sum"].numpy()
            count = int(post._buffers["row_count"].numpy().sum())
            expected = ev_from_log_sum(float(rows.sum()), count)
            record = post.exposure.numpy()[0]
            if exact:
                assert post.last_exposure_ev == expected and record["scale"] == np.float32(2.0**expected)
            else:
                assert post.last_exposure_ev == pytest.approx(expected, rel=1e-12, abs=1e-12)
                assert record["scale"] == pytest.approx(np.float32(2.0**expected), rel=1e-6)


def test_device_exposure_edge_cases(device):
    with Launcher(device) as launcher:
        post = PostProcess(launcher)
        assert post.last_exposure_ev == 0.0  # before any frame
        # no pixel qualifies: EV 0, scale 1
        post.auto_exposure(wp.zeros((4, 5), dtype=wp.vec3, device=device), None)
        assert post.last_exposure_ev == 0.0 and post.exposure.numpy()[0]["scale"] == 1.0
        # far too bright: clamped to -EV_LIMIT
        bright = wp.array(np.full((4, 5, 3), 1e12, np.float32), dtype=wp.vec3, device=device)
        post.auto_exposure(bright, None)
        assert post.last_exposure_ev == -EV_LIMIT
        # a fixed EV comes from the host as it is
        post.set_exposure(1.37)
        assert post.last_exposure_ev == 1.37 and post.exposure.numpy()[0]["scale"] == np.float32(2.0**1.37)


def test_exposure_reads_nothing_back(device, monkeypatch):
    """Neither exposure path reads device memory or synchronises the host."""
    rng = np.random.default_rng(2)
    color = wp.array(_hdr(rng, 16, 24), dtype=wp.vec3, device=device)
    ids = wp.array(np.where(rng.random((16, 24)) > 0.5, 1, -1).astype(np.int32), dtype=wp.int32, device=device)
    with Launcher(device, threads=2) as launcher:
        post = PostProcess(launcher)
        post.auto_exposure(color, ids)  # allocates the buffers
        expected = post.last_exposure_ev

        def forbidden(*args, **kwargs):
            raise AssertionError("host readback or sync inside the frame")

        with monkeypatch.context() as patch:
            patch.setattr(wp.array, "numpy", forbidden)
            patch.setattr(wp, "synchronize", forbidden)
            patch.setattr(wp, "synchronize_device", forbidden)
            post.set_exposure(2.0)
            post.auto_exposure(color, ids)
        assert post.last_exposure_ev == expected
