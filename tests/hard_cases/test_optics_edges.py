"""Dielectric edge cases: total internal reflection just beyond the critical angle,
exact normal incidence, IOR 1 (invisible glass), and refraction chains cut at every
depth (issue 10, cases 4 and 9)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from hard_kit import render

from warp_hybrid.lighting.brdf import fresnel_dielectric
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Environment, Light, LightKind, Material
from warp_hybrid.trace.optics import refract_direction


@wp.kernel
def _refract(cos_i: wp.array(dtype=float), eta: float, out: wp.array(dtype=wp.vec4), fres: wp.array(dtype=float)):
    i = wp.tid()
    c = cos_i[i]
    d = wp.vec3(wp.sqrt(wp.max(1.0 - c * c, 0.0)), -c, 0.0)
    out[i] = refract_direction(d, wp.vec3(0.0, 1.0, 0.0), eta)
    fres[i] = fresnel_dielectric(c, eta)


def _run(device, cos_i, eta):
    c = wp.array(np.asarray(cos_i, np.float32), dtype=float, device=device)
    out = wp.zeros(len(cos_i), dtype=wp.vec4, device=device)
    fres = wp.zeros(len(cos_i), dtype=float, device=device)
    wp.launch(_refract, len(cos_i), [c, float(eta), out, fres], device=device)
    return out.numpy().astype(np.float64), fres.numpy().astype(np.float64)


def test_total_internal_reflection_beyond_the_critical_angle(device):
    eta = 1.0 / 1.5  # leaving glass
    critical = math.asin(eta)
    angles = critical + np.radians([-1.0, -0.05, -0.005, 0.005, 0.05, 1.0, 20.0, 48.0])
    t, f = _run(device, np.cos(angles), eta)
    inside = angles < critical
    assert np.all(np.isfinite(t)) and np.all(np.isfinite(f))
    assert np.all(t[inside, 3] == 1.0) and np.all(t[~inside, 3] == 0.0)
    assert np.all(f[~inside] == 1.0) and np.all(f[inside] < 1.0)
    sin_t = np.hypot(t[inside, 0], t[inside, 2])
    np.testing.assert_allclose(sin_t, np.sin(angles[inside]) / eta, rtol=0, atol=2e-4)  # Snell's law


@pytest.mark.parametrize("eta", [1.5, 1.0 / 1.5, 1.0])
def test_exact_normal_incidence(device, eta):
    t, f = _run(device, [1.0], eta)
    np.testing.assert_array_equal(t[0], [0.0, -1.0, 0.0, 1.0])  # straight on, no NaN
    assert f[0] == pytest.approx(((eta - 1.0) / (eta + 1.0)) ** 2, abs=1e-6)


def _backdrop():
    cam = look_at_camera((0.0, 0.6, 3.0), (0.0, 0.4, 0.0), hfov_deg=45.0)
    sun = Light(LightKind.DISTANT, "/sun", (2.0, 2.0, 2.0), direction=(-0.3, -1.0, -0.4))
    floor = quad((-2.0, 0.0, 2.0), (4.0, 0.0, 0.0), (0.0, 0.0, -4.0), 0)
    back = quad((-2.0, 0.0, -1.0), (4.0, 0.0, 0.0), (0.0, 2.0, 0.0), 1)
    mats = [Material("/floor", diffuse=(0.7, 0.7, 0.7)), Material("/back", diffuse=(0.2, 0.5, 0.8))]
    return [floor, back], mats, sun, cam


def test_ior_one_glass_is_invisible(device):
    meshes, mats, sun, cam = _backdrop()
    env = Environment("/sky", (0.3, 0.3, 0.4))
    without = render(make_scene(meshes, mats, lights=[sun], cameras=[cam], environment=env), device)
    glass = Material("/clear", diffuse=(1.0, 1.0, 1.0), opacity=0.0, ior=1.0, roughness=0.0)
    ball = uv_sphere((0.0, 0.45, 0.5), 0.35, rings=16, segments=32, material=2)
    with_ball = render(
        make_scene(meshes + [ball], mats + [glass], lights=[sun], cameras=[cam], environment=env), device
    )
    covered = with_ball.triangle_id >= 4  # pixels that see the ball first
    assert covered.sum() > 100
    np.testing.assert_allclose(with_ball.color, without.color, rtol=1e-4, atol=1e-6)
    # the clear ball casts no shadow (visibility of the points both frames see first)
    np.testing.assert_array_equal(with_ball.view.visibility[~covered], without.view.visibility[~covered])


@pytest.mark.parametrize("max_depth", [0, 1, 2, 5, 8])
def test_depth_limited_refraction_chains_end_in_a_defined_colour(device, max_depth):
    """Five nested glass shells in front of the camera: every path is cut at max_depth
    and ends in finite, non-negative radiance."""
    meshes, mats, sun, cam = _backdrop()
    glass = Material("/glass", diffuse=(0.9, 1.0, 0.9), opacity=0.0, ior=1.5, roughness=0.0)
    shells = [uv_sphere((0.0, 0.45, 0.5), r, rings=12, segments=24, material=2) for r in (0.4, 0.3, 0.2, 0.12, 0.06)]
    scene = make_scene(
        meshes + shells, mats + [glass], lights=[sun], cameras=[cam], environment=Environment("/sky", (0.4, 0.4, 0.5))
    )
    out = render(scene, device, max_depth=max_depth)
    assert np.isfinite(out.color).all() and (out.color >= 0.0).all()
    assert np.isfinite(out.view.image).all()
    glass_px = out.triangle_id >= 4
    assert glass_px.sum() > 100 and out.color[glass_px].max() > 0.0
