"""Irradiance from each light kind against closed forms and numerical quadrature."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.scene_gpu import LightGPU
from warp_hybrid.lighting.lights import light_sample, subtended_angle
from warp_hybrid.scene.authoring.builders import make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Light, LightKind, Material

wp.set_module_options({"enable_backward": False})


@wp.kernel
def sample_kernel(
    lights: wp.array(dtype=LightGPU),
    p: wp.array(dtype=wp.vec3),
    n: wp.array(dtype=wp.vec3),
    wi: wp.array(dtype=wp.vec3),
    dist: wp.array(dtype=float),
    e_normal: wp.array(dtype=wp.vec3),
    irradiance: wp.array(dtype=wp.vec3),
):
    i = wp.tid()
    s = light_sample(lights[0], p[i], n[i])
    wi[i] = s.wi
    dist[i] = s.distance
    e_normal[i] = s.e_normal
    irradiance[i] = s.irradiance


@wp.kernel
def angle_kernel(s: wp.array(dtype=float), c: wp.array(dtype=float), out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = subtended_angle(s[i], c[i])


def test_subtended_angle_matches_atan2(device):
    theta = np.concatenate([np.linspace(0.0, math.pi, 10001), [1e-6, 1e-4, math.pi - 1e-4]])
    scale = np.geomspace(1e-3, 1e3, len(theta))
    s = (np.sin(theta) * scale).astype(np.float32)
    c = (np.cos(theta) * scale).astype(np.float32)
    out = wp.zeros(len(theta), dtype=float, device=device)
    wp.launch(
        angle_kernel,
        dim=len(theta),
        inputs=[wp.array(s, dtype=float, device=device), wp.array(c, dtype=float, device=device)],
        outputs=[out],
        device=device,
    )
    ref = np.arctan2(s.astype(np.float64), c.astype(np.float64))
    got = out.numpy()
    assert np.abs(got - ref).max() < 1e-5
    small = (ref > 0.0) & (ref < 0.01)
    assert np.abs(got[small] / ref[small] - 1.0).max() < 1e-5  # relative accuracy for tiny edges


def _sample(device: str, light: Light, points, normals) -> dict[str, np.ndarray]:
    scene = make_scene([quad((0, 0, 0), (1, 0, 0), (0, 1, 0))], [Material("m")], lights=[light])
    ds = DeviceScene(scene, device)
    p = np.asarray(points, np.float32).reshape(-1, 3)
    nrm = np.broadcast_to(np.asarray(normals, np.float32).reshape(-1, 3), p.shape).copy()
    count = len(p)
    out = {
        "wi": wp.zeros(count, dtype=wp.vec3, device=device),
        "distance": wp.zeros(count, dtype=float, device=device),
        "e_normal": wp.zeros(count, dtype=wp.vec3, device=device),
        "irradiance": wp.zeros(count, dtype=wp.vec3, device=device),
    }
    wp.launch(
        sample_kernel,
        dim=count,
        inputs=[ds.lights, wp.array(p, dtype=wp.vec3, device=device), wp.array(nrm, dtype=wp.vec3, device=device)],
        outputs=list(out.values()),
        device=device,
    )
    return {k: a.numpy() for k, a in out.items()}


def test_distant_light_cosine_law(device):
    theta = np.radians([0.0, 30.0, 60.0, 89.0, 120.0])
    color = (2.0, 1.0, 0.5)
    results = []
    for t in theta:
        direction = (-math.sin(t), -math.cos(t), 0.0)  # photons travel this way
        s = _sample(device, Light(LightKind.DISTANT, "/sun", color, direction=direction), [(0, 0, 0)], (0, 1, 0))
        results.append(s)
        np.testing.assert_allclose(s["wi"][0], -np.array(direction), atol=1e-6)
        assert s["distance"][0] == np.inf
        np.testing.assert_allclose(s["e_normal"][0], color, rtol=1e-6)
    irr = np.array([r["irradiance"][0] for r in results])
    np.testing.assert_allclose(irr, np.outer(np.maximum(np.cos(theta), 0.0), color), rtol=1e-5, atol=1e-7)


def test_sphere_light_inverse_square(device):
    d = np.array([0.5, 1.0, 2.0, 4.0, 8.0])
    pts = np.stack([np.zeros_like(d), -d, np.zeros_like(d)], axis=1)
    color = np.array([3.0, 2.0, 1.0])
    s = _sample(device, Light(LightKind.SPHERE, "/bulb", tuple(color), radius=0.25), pts, (0, 1, 0))
    expected = np.outer(math.pi * 0.25**2 / d**2, color)
    np.testing.assert_allclose(s["e_normal"], expected, rtol=1e-5)
    np.testing.assert_allclose(s["irradiance"], expected, rtol=1e-5)
    np.testing.assert_allclose(s["distance"], d, rtol=1e-6)
    np.testing.assert_allclose(s["wi"], np.tile([0.0, 1.0, 0.0], (len(d), 1)), atol=1e-6)
    # a tilted receiver gets the cosine; a receiver facing away gets nothing
    tilt = _sample(
        device,
        Light(LightKind.SPHERE, "/bulb", tuple(color), radius=0.25),
        [(0, -2, 0)] * 2,
        [(0, 0.6, 0.8), (0, -1, 0)],
    )
    np.testing.assert_allclose(tilt["irradiance"][0], 0.6 * math.pi * 0.0625 / 4.0 * color, rtol=1e-5)
    np.testing.assert_array_equal(tilt["irradiance"][1], 0.0)
    # normalize: power independent of radius => E = color / (4 d^2)
    for radius in (0.1, 0.5):
        norm = _sample(
            device, Light(LightKind.SPHERE, "/b", tuple(color), radius=radius, normalize=True), pts[2:], (0, 1, 0)
        )
        np.testing.assert_allclose(norm["e_normal"], np.outer(1.0 / (4.0 * d[2:] ** 2), color), rtol=1e-5)
    # radius 0: a point light with intensity = color
    point = _sample(device, Light(LightKind.SPHERE, "/p", tuple(color), radius=0.0), pts, (0, 1, 0))
    np.testing.assert_allclose(point["e_normal"], np.outer(1.0 / d**2, color), rtol=1e-5)
    # inside the sphere the irradiance saturates at pi L
    inside = _sample(device, Light(LightKind.SPHERE, "/b", tuple(color), radius=1.0), [(0, -0.5, 0)], (0, 1, 0))
    np.testing.assert_allclose(inside["e_normal"][0], math.pi * color, rtol=1e-5)


def _rect_quadrature(p, n, center, u, v, direction, radiance, k=600) -> float:
    """E = L * integral of cos_r+ cos_e+ / r^2 dA over the rectangle (midpoint rule)."""
    s = (np.arange(k) + 0.5) / k * 2.0 - 1.0
    a, b = np.meshgrid(s, s, indexing="ij")
    x = center + a[..., None] * u + b[..., None] * v
    d = x - p
    r2 = np.sum(d * d, axis=-1)
    r = np.sqrt(r2)
    cos_r = np.maximum(d @ n / r, 0.0)
    cos_e = np.maximum(-(d @ direction) / r, 0.0)
    area = 4.0 * np.linalg.norm(np.cross(u, v))
    return float(radiance * np.sum(cos_r * cos_e / r2) * area / (k * k))


RECT_CASES = [
    # (point, normal): below the centre, off-axis tilted, crossing the receiver's horizon, grazing
    ((0.0, -1.0, 0.0), (0.0, 1.0, 0.0)),
    ((0.7, -0.8, 0.3), (0.3, 0.9, -0.3)),
    ((1.5, -0.4, 0.0), (-1.0, 0.3, 0.2)),
    ((0.2, -0.6, -0.1), (1.0, 0.05, 0.0)),
    ((0.0, -0.5, 0.0), (0.0, 1.0, 0.0)),
]


@pytest.mark.parametrize("flip_winding", [False, True])
def test_rect_light_matches_form_factor_quadrature(device, flip_winding):
    center = np.array([0.0, 0.0, 0.0])
    u = np.array([0.5, 0.0, 0.0])
    v = np.array([0.0, 0.0, 0.35])
    if flip_winding:
        u = -u
    direction = np.array([0.0, -1.0, 0.0])  # emits downwards
    light = Light(
        LightKind.RECT,
        "/rect",
        (2.0, 2.0, 2.0),
        position=tuple(center),
        direction=tuple(direction),
        axis_u=tuple(u),
        axis_v=tuple(v),
    )
    pts = [c[0] for c in RECT_CASES]
    nrm = [np.array(c[1]) / np.linalg.norm(c[1]) for c in RECT_CASES]
    s = _sample(device, light, pts, nrm)
    for i, (p, n) in enumerate(zip(pts, nrm)):
        ref = _rect_quadrature(np.array(p), n, center, u, v, direction, 2.0)
        assert s["irradiance"][i][0] == pytest.approx(ref, rel=2e-3, abs=1e-5), (p, n)
    # one-sided: a point behind the emitting side gets nothing
    behind = _sample(device, light, [(0.0, 1.0, 0.0)], (0, -1, 0))
    np.testing.assert_array_equal(behind["irradiance"], 0.0)
    np.testing.assert_array_equal(behind["e_normal"], 0.0)


def _rect_polygon_reference(p, n, center, u, v, direction) -> float:
    """E / L from Lambert's polygon formula in float64: the rectangle clipped to the
    horizon of (p, n) (Sutherland-Hodgman), sum_i theta_i (n . gamma_i) / 2."""
    if np.dot(p - center, direction) <= 0.0:
        return 0.0
    corners = [center - u - v, center + u - v, center + u + v, center - u + v]
    poly = []
    for k in range(4):
        a = corners[k] - p
        b = corners[(k + 1) % 4] - p
        ha, hb = a @ n, b @ n
        if ha > 0.0:
            poly.append(a)
        if (ha > 0.0) != (hb > 0.0):
            poly.append(a + (b - a) * (ha / (ha - hb)))
    total = 0.0
    for k in range(len(poly)):
        a, b = poly[k], poly[(k + 1) % len(poly)]
        c = np.cross(a, b)
        lc = np.linalg.norm(c)
        if lc > 0.0:
            total += math.atan2(lc, a @ b) * (c @ n) / lc
    if np.dot(np.cross(u, v), direction) > 0.0:
        total = -total
    return min(max(0.5 * total, 0.0), math.pi)


def test_rect_light_matches_polygon_formula_everywhere(device):
    # random points around a tilted rect and random normals: wholly above the horizon
    # (the fast 4-lane path), crossing it (the clipped path), below it, behind the light
    rng = np.random.default_rng(7)
    center = np.array([0.2, 1.0, -0.3])
    u = np.array([0.6, 0.1, 0.0])
    v = np.array([0.0, -0.1, 0.45])
    direction = np.cross(v, u) / np.linalg.norm(np.cross(v, u))
    pts = center + rng.normal(size=(3000, 3)) * 1.5
    nrm = rng.normal(size=(3000, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    light = Light(
        LightKind.RECT,
        "/rect",
        (1.0, 1.0, 1.0),
        position=tuple(center),
        direction=tuple(direction),
        axis_u=tuple(u),
        axis_v=tuple(v),
    )
    got = _sample(device, light, pts, nrm)["irradiance"][:, 0]
    ref = np.array([_rect_polygon_reference(p, n, center, u, v, direction) for p, n in zip(pts, nrm)])
    corners = np.stack([center + su * u + sv * v for su in (-1, 1) for sv in (-1, 1)])
    heights = np.einsum("pk,cpk->pc", nrm, corners[:, None, :] - pts[None])
    crossing = (heights > 0.0).any(axis=1) & (heights <= 0.0).any(axis=1)
    assert crossing.sum() > 300 and (ref > 0.0).sum() > 800  # both paths are exercised
    np.testing.assert_allclose(got, ref, rtol=1e-4, atol=1e-5)


def test_rect_light_far_field_and_normalize(device):
    u = np.array([0.3, 0.0, 0.0])
    v = np.array([0.0, 0.2, 0.0])
    area = 4 * 0.3 * 0.2
    direction = np.array([0.0, 0.0, 1.0])  # rect in the XY plane, emitting toward +Z
    radiance = 5.0
    light = Light(
        LightKind.RECT, "/rect", (radiance,) * 3, direction=tuple(direction), axis_u=tuple(u), axis_v=tuple(v)
    )
    d = 40.0
    p = np.array([0.3 * d, 0.0, d])
    to_light = -p / np.linalg.norm(p)
    n = np.array([0.0, 0.6, -0.8])
    s = _sample(device, light, [p], n)
    r2 = float(p @ p)
    cos_e = float(-to_light @ direction)
    cos_r = float(to_light @ n)
    far = radiance * area * cos_e * cos_r / r2
    assert s["irradiance"][0][0] == pytest.approx(far, rel=2e-3)
    assert s["e_normal"][0][0] == pytest.approx(radiance * area * cos_e / r2, rel=1e-5)
    np.testing.assert_allclose(s["wi"][0], to_light, atol=1e-6)
    assert s["distance"][0] == pytest.approx(math.sqrt(r2), rel=1e-6)
    norm = _sample(
        device,
        Light(
            LightKind.RECT,
            "/r",
            (radiance,) * 3,
            direction=tuple(direction),
            axis_u=tuple(u),
            axis_v=tuple(v),
            normalize=True,
        ),
        [p],
        n,
    )
    assert norm["irradiance"][0][0] == pytest.approx(far / area, rel=2e-3)


def test_disk_light_point_form_factor(device):
    r = 0.3
    light = Light(LightKind.DISK, "/disk", (4.0, 4.0, 4.0), direction=(0.0, -1.0, 0.0), radius=r)
    p = np.array([1.0, -2.0, 0.0])
    dist = np.linalg.norm(p)
    s = _sample(device, light, [p], (0, 1, 0))
    cos = 2.0 / dist
    assert s["irradiance"][0][0] == pytest.approx(4.0 * math.pi * r * r * cos * cos / dist**2, rel=1e-5)
    normalized = _sample(
        device, Light(LightKind.DISK, "/d", (4.0,) * 3, direction=(0, -1, 0), radius=r, normalize=True), [p], (0, 1, 0)
    )
    assert normalized["irradiance"][0][0] == pytest.approx(4.0 * cos * cos / dist**2, rel=1e-5)


def test_spot_cone(device):
    def spot(softness: float) -> Light:
        return Light(
            LightKind.SPHERE,
            "/spot",
            (1.0, 1.0, 1.0),
            direction=(0.0, -1.0, 0.0),
            radius=0.1,
            cone_angle_deg=30.0,
            cone_softness=softness,
        )

    angles = np.radians([0.0, 10.0, 20.0, 29.0, 31.0, 60.0, 120.0])
    pts = np.stack([np.sin(angles), -np.cos(angles), np.zeros_like(angles)], axis=1) * 2.0
    normals = -pts / 2.0
    hard = _sample(device, spot(0.0), pts, normals)["irradiance"][:, 0]
    full = math.pi * 0.01 / 4.0
    np.testing.assert_allclose(hard[:4], full, rtol=1e-5)
    np.testing.assert_array_equal(hard[4:], 0.0)
    soft = _sample(device, spot(0.5), pts, normals)["irradiance"][:, 0]  # full inside 15 deg
    np.testing.assert_allclose(soft[:2], full, rtol=1e-5)
    assert 0.0 < soft[3] < soft[2] < full
    np.testing.assert_array_equal(soft[4:], 0.0)
