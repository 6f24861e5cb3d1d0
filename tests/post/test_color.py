"""sRGB transfer functions (host and kernel) and tone-mapping operators."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.post.color import (
    Srgb8Encoder,
    luminance,
    make_srgb8_encoder,
    srgb_decode,
    srgb_encode,
    srgb_quantize,
    srgb_thresholds,
)
from warp_hybrid.post.tonemap import tonemap_aces, tonemap_clamp, tonemap_reinhard

wp.set_module_options({"enable_backward": False})


@wp.kernel
def curves_kernel(
    x: wp.array(dtype=wp.vec3),
    encoder: Srgb8Encoder,
    srgb: wp.array(dtype=wp.vec3),
    aces: wp.array(dtype=wp.vec3),
    reinhard: wp.array(dtype=wp.vec3),
    clamped: wp.array(dtype=wp.vec3),
):
    i = wp.tid()
    srgb[i] = wp.vec3(float(srgb_quantize(x[i][0], encoder)), 0.0, 0.0)
    aces[i] = tonemap_aces(x[i])
    reinhard[i] = tonemap_reinhard(x[i])
    clamped[i] = tonemap_clamp(x[i])


def _curves(device: str, values: np.ndarray) -> dict[str, np.ndarray]:
    x = np.repeat(np.asarray(values, np.float32)[:, None], 3, axis=1)
    outs = {k: wp.zeros(len(x), dtype=wp.vec3, device=device) for k in ("srgb", "aces", "reinhard", "clamped")}
    inputs = [wp.array(x, dtype=wp.vec3, device=device), make_srgb8_encoder(device)]
    wp.launch(curves_kernel, dim=len(x), inputs=inputs, outputs=list(outs.values()), device=device)
    return {k: a.numpy()[:, 0] for k, a in outs.items()}


def test_srgb_breakpoints_and_round_trip():
    assert srgb_encode(np.array([0.0031308]))[0] == pytest.approx(0.0404500, abs=1e-6)
    assert srgb_decode(np.array([0.04045]))[0] == pytest.approx(0.0031308, abs=1e-7)
    np.testing.assert_allclose(
        srgb_encode(np.array([0.0, 0.001, 0.18, 0.5, 1.0, 2.0])),
        [0.0, 0.01292, 0.461356, 0.735357, 1.0, 1.0],
        atol=2e-6,
    )
    np.testing.assert_allclose(srgb_decode(np.array([0, 128, 255], np.uint8)), [0.0, 0.2158605, 1.0], atol=1e-6)
    x = np.linspace(0.0, 1.0, 2001)
    np.testing.assert_allclose(srgb_decode(srgb_encode(x)), x, atol=2e-6)
    s = np.linspace(0.0, 1.0, 2001)
    np.testing.assert_allclose(srgb_encode(srgb_decode(s)), s, atol=2e-6)
    assert luminance(np.array([1.0, 1.0, 1.0])) == pytest.approx(1.0)


def test_kernel_curves(device):
    x = np.concatenate([np.linspace(0.0, 1.0, 501), np.geomspace(1.0, 1000.0, 200)])
    c = _curves(device, x)
    # the kernels' 8-bit encoder is round(255 * encode(x)); code k + 1 starts at step k
    dense = np.linspace(-0.1, 1.2, 20001).astype(np.float32)
    np.testing.assert_array_equal(_curves(device, dense)["srgb"], np.round(srgb_encode(dense) * 255.0))
    steps = srgb_thresholds().astype(np.float32)
    np.testing.assert_array_equal(_curves(device, steps)["srgb"], np.arange(1, 256))
    np.testing.assert_array_equal(_curves(device, np.nextafter(steps, np.float32(0.0)))["srgb"], np.arange(0, 255))
    np.testing.assert_array_equal(_curves(device, np.array([np.inf, -np.inf, np.nan], np.float32))["srgb"], [255, 0, 0])
    for name in ("aces", "reinhard", "clamped"):
        y = c[name]
        assert y[0] == 0.0, name
        assert np.all(np.diff(y) >= 0.0), name  # monotone
        assert y.max() <= 1.0 and y.min() >= 0.0, name
    np.testing.assert_allclose(c["reinhard"], x / (1.0 + x), rtol=1e-6)
    assert c["aces"][-1] == 1.0 and c["aces"][250] == pytest.approx(
        0.5 * (2.51 * 0.5 + 0.03) / (0.5 * (2.43 * 0.5 + 0.59) + 0.14), rel=1e-6
    )
    np.testing.assert_allclose(c["clamped"], np.clip(x, 0.0, 1.0))
    # negative input (e.g. from bias) maps to black
    assert _curves(device, np.array([-1.0]))["aces"][0] == 0.0
