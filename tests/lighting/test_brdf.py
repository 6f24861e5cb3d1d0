"""The reflection model against analytic values: Fresnel, GGX normalisation,
reciprocity and energy bounds (directional albedo <= 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from warp_hybrid.lighting.brdf import (
    brdf_diffuse,
    brdf_specular,
    diffuse_view_weight,
    fresnel_dielectric,
    fresnel_schlick,
    ggx_d,
)
from warp_hybrid.scene.device.dome import specular_albedo_table

wp.set_module_options({"enable_backward": False})


@wp.func(inline=True)
def brdf_eval(n: wp.vec3, v: wp.vec3, l: wp.vec3, albedo: wp.vec3, f0: wp.vec3, roughness: float) -> wp.vec3:
    """The whole BRDF f(v, l) (1/sr); zero when ``l`` is below the horizon."""
    if wp.dot(n, l) <= 0.0:
        return wp.vec3(0.0, 0.0, 0.0)
    return brdf_diffuse(n, v, l, albedo, f0) + brdf_specular(n, v, l, f0, roughness)


@wp.kernel
def eval_brdf_kernel(
    n: wp.array(dtype=wp.vec3),
    v: wp.array(dtype=wp.vec3),
    l: wp.array(dtype=wp.vec3),
    albedo: wp.vec3,
    f0: wp.vec3,
    roughness: float,
    out: wp.array(dtype=wp.vec3),
):
    i = wp.tid()
    out[i] = brdf_eval(n[i], v[i], l[i], albedo, f0, roughness)


@wp.kernel
def eval_scalar_kernel(
    x: wp.array(dtype=float),
    y: wp.array(dtype=float),
    f0: wp.vec3,
    dielectric: wp.array(dtype=float),
    schlick: wp.array(dtype=wp.vec3),
    ggx: wp.array(dtype=float),
    diffuse_weight: wp.array(dtype=wp.vec3),
):
    i = wp.tid()
    dielectric[i] = fresnel_dielectric(x[i], y[i])
    schlick[i] = fresnel_schlick(f0, x[i])
    ggx[i] = ggx_d(x[i], y[i])
    diffuse_weight[i] = diffuse_view_weight(f0, x[i])


def _scalars(device: str, x: np.ndarray, y: np.ndarray, f0=(0.04, 0.04, 0.04)) -> dict[str, np.ndarray]:
    x = np.asarray(x, np.float32)
    y = np.broadcast_to(np.asarray(y, np.float32), x.shape).copy()
    outs = {
        "dielectric": wp.zeros(len(x), dtype=float, device=device),
        "schlick": wp.zeros(len(x), dtype=wp.vec3, device=device),
        "ggx": wp.zeros(len(x), dtype=float, device=device),
        "diffuse_weight": wp.zeros(len(x), dtype=wp.vec3, device=device),
    }
    wp.launch(
        eval_scalar_kernel,
        dim=len(x),
        inputs=[wp.array(x, dtype=float, device=device), wp.array(y, dtype=float, device=device), wp.vec3(*f0)],
        outputs=list(outs.values()),
        device=device,
    )
    return {k: a.numpy() for k, a in outs.items()}


def _brdf(device: str, n, v, l, albedo, f0, roughness) -> np.ndarray:
    arrs = [wp.array(np.asarray(a, np.float32).reshape(-1, 3), dtype=wp.vec3, device=device) for a in (n, v, l)]
    out = wp.zeros(arrs[0].shape[0], dtype=wp.vec3, device=device)
    wp.launch(
        eval_brdf_kernel,
        dim=out.shape[0],
        inputs=[*arrs, wp.vec3(*albedo), wp.vec3(*f0), float(roughness)],
        outputs=[out],
        device=device,
    )
    return out.numpy()


def _exact_fresnel(cos_i: float, eta: float) -> float:
    sin_t = math.sqrt(1.0 - cos_i**2) / eta
    if sin_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(1.0 - sin_t**2)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (rs * rs + rp * rp)


def test_fresnel_dielectric_normal_incidence_and_tir(device):
    crit = math.asin(1.0 / 1.5)
    cos_in = np.array([1.0, 1.0, math.cos(crit - 0.01), math.cos(crit + 0.01), 0.1, math.cos(1.0)])
    eta = np.array([1.5, 1.0 / 1.5, 1.0 / 1.5, 1.0 / 1.5, 1.0 / 1.5, 1.5])
    r = _scalars(device, cos_in, eta)["dielectric"]
    assert r[0] == pytest.approx(0.04, abs=1e-6)
    assert r[1] == pytest.approx(0.04, abs=1e-6)
    assert r[2] < 1.0 and r[2] == pytest.approx(_exact_fresnel(cos_in[2], eta[2]), rel=1e-4)
    assert r[3] == 1.0 and r[4] == 1.0
    assert r[5] == pytest.approx(_exact_fresnel(math.cos(1.0), 1.5), rel=1e-5)


def test_schlick_endpoints(device):
    f0 = (0.04, 0.5, 0.9)
    s = _scalars(device, np.array([1.0, 0.0, 0.5]), 0.5, f0)["schlick"]
    np.testing.assert_allclose(s[0], f0, atol=1e-7)
    np.testing.assert_allclose(s[1], (1.0, 1.0, 1.0), atol=1e-6)
    np.testing.assert_allclose(s[2], np.array(f0) + (1 - np.array(f0)) * 0.5**5, atol=1e-6)
    # a surface without specular colour has no Fresnel at all (exact Lambertian)
    z = _scalars(device, np.array([0.0, 0.3]), 0.5, (0.0, 0.0, 0.0))
    np.testing.assert_array_equal(z["schlick"], 0.0)
    np.testing.assert_array_equal(z["diffuse_weight"], 1.0)


@pytest.mark.parametrize("roughness", [0.2, 0.5, 1.0])
def test_ggx_distribution_is_normalised(device, roughness):
    # integral of D(h) (n.h) over the hemisphere = 1, in cos(theta_h) with a fine grid
    k = 200000
    mu = (np.arange(k) + 0.5) / k
    alpha = max(roughness**2, 1e-3)
    d = _scalars(device, mu, alpha)["ggx"]
    integral = np.sum(d * mu) * 2.0 * math.pi / k
    assert integral == pytest.approx(1.0, abs=2e-3)


def _hemisphere_grid(n_theta: int, n_phi: int) -> tuple[np.ndarray, np.ndarray]:
    """Directions on the upper hemisphere (z up) and their solid angles."""
    mu = (np.arange(n_theta) + 0.5) / n_theta  # cos(theta), uniform => equal-area bands
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2.0 * math.pi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - m * m)
    dirs = np.stack([s * np.cos(p), s * np.sin(p), m], axis=-1).reshape(-1, 3)
    return dirs, np.full(len(dirs), 2.0 * math.pi / (n_theta * n_phi))


def _directional_albedo(device, theta_v, albedo, f0, roughness, grid=(1000, 256)) -> np.ndarray:
    dirs, dw = _hemisphere_grid(*grid)
    v = np.array([math.sin(theta_v), 0.0, math.cos(theta_v)])
    n = np.tile([0.0, 0.0, 1.0], (len(dirs), 1))
    f = _brdf(device, n, np.tile(v, (len(dirs), 1)), dirs, albedo, f0, roughness)
    return (f * (dirs[:, 2] * dw)[:, None]).sum(axis=0)


@pytest.mark.parametrize("roughness", [0.3, 0.6, 1.0])
def test_white_furnace_specular_and_combined(device, roughness):
    table = specular_albedo_table()
    size = table.shape[0]
    rows = np.array(
        [np.interp(roughness * (size - 1), np.arange(size), table[:, j, k]) for j in range(size) for k in range(2)]
    )
    rows = rows.reshape(size, 2)
    for theta in (0.0, 0.6, 1.2, 1.45):
        spec = _directional_albedo(device, theta, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), roughness)
        # the single-scattering GGX lobe loses energy but never creates it
        assert spec.max() <= 1.0 + 5e-3
        both = _directional_albedo(device, theta, (1.0, 1.0, 1.0), (0.04, 0.04, 0.04), roughness)
        assert both.max() <= 1.0 + 5e-3
        if theta == 0.0:
            assert both.min() >= 0.95  # little lost at normal incidence
        if theta <= 1.2:
            # the split-sum table used for the dome's glossy light is this same integral
            # (not compared at grazing angles, where this quadrature grid is too coarse)
            col = np.clip(math.cos(theta) * size - 0.5, 0, size - 1)
            ab = [np.interp(col, np.arange(size), rows[:, k]) for k in range(2)]
            assert ab[0] + ab[1] == pytest.approx(spec[0], abs=0.01)
    if roughness == 1.0:
        # alpha = 1: D = 1/pi, Vis = 0.5/(n.l + n.v) => albedo(n.v = 1) = 1 - ln 2
        at_normal = _directional_albedo(device, 0.0, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 1.0)
        assert at_normal[0] == pytest.approx(1.0 - math.log(2.0), abs=1e-3)


def test_lambert_only_and_reciprocity(device):
    rng = np.random.default_rng(3)
    n = np.tile([0.0, 0.0, 1.0], (500, 1))
    v = rng.normal(size=(500, 3))
    l = rng.normal(size=(500, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    l[:, 2] = np.abs(l[:, 2]) + 0.05
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    l /= np.linalg.norm(l, axis=1, keepdims=True)
    albedo, f0 = (0.7, 0.5, 0.2), (0.04, 0.3, 0.9)
    a = _brdf(device, n, v, l, albedo, f0, 0.35)
    b = _brdf(device, n, l, v, albedo, f0, 0.35)
    np.testing.assert_allclose(a, b, rtol=2e-5, atol=1e-6)
    lambert = _brdf(device, n, v, l, albedo, (0.0, 0.0, 0.0), 0.35)  # no specular: exact Lambert
    np.testing.assert_allclose(lambert, np.tile(np.array(albedo) / math.pi, (500, 1)), rtol=1e-6)
    below = _brdf(device, n, v, l * np.array([1.0, 1.0, -1.0]), albedo, f0, 0.35)
    np.testing.assert_array_equal(below, 0.0)


def test_roughness_zero_is_finite(device):
    n = np.array([[0.0, 0.0, 1.0]] * 2)
    v = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    l = np.array([[0.0, 0.0, 1.0], [-0.6, 0.0, 0.8]])
    f = _brdf(device, n, v, l, (0.5, 0.5, 0.5), (1.0, 1.0, 1.0), 0.0)
    assert np.all(np.isfinite(f)) and f.min() > 1000.0
