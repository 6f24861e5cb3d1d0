"""No acne, no leaks: shadow and mirror rays from every pixel of a flat plane with the
light at normal and at grazing incidence, a tiny object on a huge ground, and an area
light whose shadow rays end on the wall it is mounted on (issue 10, cases 3 and 5)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hard_kit import render

from warp_hybrid.scene.authoring.builders import MeshInput, look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Environment, Light, LightKind, Material


def _plane_grid(n: int, size: float, center: np.ndarray) -> MeshInput:
    """A jittered n x n tessellation of the plane y = center.y (many shared edges)."""
    rng = np.random.default_rng(1)
    s, t = np.meshgrid(np.linspace(-0.5, 0.5, n + 1), np.linspace(-0.5, 0.5, n + 1))
    j = rng.uniform(-0.3, 0.3, (2,) + s.shape) / n
    j[:, [0, -1], :] = 0.0
    j[:, :, [0, -1]] = 0.0
    pts = np.stack([s + j[0], np.zeros_like(s), -(t + j[1])], -1).reshape(-1, 3) * size + center
    idx = []
    for r in range(n):
        for c in range(n):
            a, b, d, e = r * (n + 1) + c, r * (n + 1) + c + 1, (r + 1) * (n + 1) + c, (r + 1) * (n + 1) + c + 1
            idx += [(a, b, d), (b, e, d)]
    return MeshInput(pts.astype(np.float32), np.asarray(idx, np.int32), 0)


@pytest.mark.parametrize("scale", [1.0e-3, 1.0, 1.0e3])
@pytest.mark.parametrize("elevation_deg", [90.0, 2.0, 0.5])
def test_plane_lit_at_normal_and_grazing_incidence_has_no_acne(device, scale, elevation_deg):
    e = math.radians(elevation_deg)
    to_light = np.array([math.cos(e), math.sin(e), 0.0])
    sun = Light(LightKind.DISTANT, "/sun", (1.0, 1.0, 1.0), direction=tuple(-to_light))
    centre = np.array([0.3, -0.2, 0.1]) * scale
    cam = look_at_camera(
        tuple(centre + np.array([0.0, 6.0, 3.0]) * scale), tuple(centre), near=0.01 * scale, far=100 * scale
    )
    scene = make_scene(
        [_plane_grid(20, 10.0 * scale, centre)], [Material("/m", roughness=0.8)], lights=[sun], cameras=[cam]
    )
    out = render(scene, device)
    hit = out.triangle_id >= 0
    assert hit.mean() > 0.9
    assert np.all(out.view.visibility[..., 0][hit] == 1.0)


@pytest.mark.parametrize("scale", [1.0e-3, 1.0, 1.0e3])
def test_mirror_rays_leave_a_flat_mirror(device, scale):
    """A tessellated mirror under a constant dome: the traced reflection of every pixel
    reaches the sky, so it equals the raster split-sum reflection of the same dome."""
    centre = np.array([0.1, 0.0, -0.2]) * scale
    cam = look_at_camera(
        tuple(centre + np.array([0.0, 3.0, 4.0]) * scale), tuple(centre), near=0.01 * scale, far=100 * scale
    )
    mirror = Material("/mirror", diffuse=(0.9, 0.9, 0.9), metallic=1.0, roughness=0.0)
    scene = make_scene(
        [_plane_grid(16, 10.0 * scale, centre)],
        [mirror],
        cameras=[cam],
        environment=Environment("/sky", (0.5, 0.7, 1.0)),
    )
    traced = render(scene, device)
    raster = render(scene, device, mode="raster")
    hit = traced.triangle_id >= 0
    assert hit.mean() > 0.8
    np.testing.assert_allclose(traced.color[hit], raster.color[hit], rtol=2e-3)


def test_tiny_cube_on_a_huge_ground_casts_its_contact_shadow(device):
    """A 1e-3 cube on a 1e4 ground, seen from 5 mm: the shadow reaches the cube's foot
    (offsets come from each hit, not from the 1e4 scene, whose scale-wide offset was
    0.15) and the ground is not acned."""
    s = 1.0e-3
    cube = [
        quad(c, u, v, 1)
        for c, u, v in [
            ((0, 0, 0), (0, s, 0), (0, 0, s)),
            ((s, 0, 0), (0, s, 0), (0, 0, s)),
            ((0, 0, 0), (s, 0, 0), (0, 0, s)),
            ((0, s, 0), (s, 0, 0), (0, 0, s)),
            ((0, 0, 0), (s, 0, 0), (0, s, 0)),
            ((0, 0, s), (s, 0, 0), (0, s, 0)),
        ]
    ]  # the cube [0, s]^3 resting on the ground
    # a 1e4 ground whose patch around the cube is 1 cm wide (an offset bound is 2^-16 of
    # its triangle's extent: a single 1e4 triangle could not hold a 1e-3 contact shadow)
    h, r = 0.005, 5.0e3
    ground = [
        quad((-h, 0.0, h), (2 * h, 0.0, 0.0), (0.0, 0.0, -2 * h), 0),
        quad((-r, 0.0, r), (r - h, 0.0, 0.0), (0.0, 0.0, -2 * r), 0),
        quad((h, 0.0, r), (r - h, 0.0, 0.0), (0.0, 0.0, -2 * r), 0),
        quad((-h, 0.0, r), (2 * h, 0.0, 0.0), (0.0, 0.0, h - r), 0),
        quad((-h, 0.0, -h), (2 * h, 0.0, 0.0), (0.0, 0.0, h - r), 0),
    ]
    sun = Light(LightKind.DISTANT, "/sun", (1.0, 1.0, 1.0), direction=(-1.0, -1.0, 0.0))  # from +x, 45 degrees up
    cam = look_at_camera((0.0005, 0.006, 0.004), (-0.0003, 0.0, 0.0005), hfov_deg=60.0, near=1e-5, far=1e4)
    scene = make_scene(ground + cube, [Material("/g"), Material("/c")], lights=[sun], cameras=[cam])
    out = render(scene, device, 96, 72)
    p = out.position.astype(np.float64)
    x, z = p[..., 0], p[..., 2]
    on_ground = (out.triangle_id >= 0) & (out.triangle_id < 10)
    vis = out.view.visibility[..., 0]
    m = 0.05 * s
    shadow = on_ground & (x > -s + m) & (x < -m) & (z > m) & (z < s - m)  # the cube's shadow, from its foot
    lit = on_ground & ((x > s + m) | (x < -s - m) | (z > s + m) | (z < -m))
    assert shadow.sum() > 20 and lit.sum() > 200
    assert np.all(vis[shadow] == 0.0)
    assert np.all(vis[lit] == 1.0)


@pytest.mark.parametrize("samples", [1, 8])
def test_area_light_on_a_wall_lights_the_floor(device, samples):
    """Shadow rays toward a rect light mounted exactly on a wall end on the wall's own
    plane: the wall must not shadow its light (no speckles at the ray's end)."""
    wall = quad((-2.0, 0.0, 0.0), (4.0, 0.0, 0.0), (0.0, 2.0, 0.0), 0)  # z = 0, facing +z
    floor = quad((-2.0, 0.0, 3.0), (4.0, 0.0, 0.0), (0.0, 0.0, -3.0), 0)
    panel = Light(
        LightKind.RECT,
        "/panel",
        (5.0, 5.0, 5.0),
        position=(0.0, 1.0, 0.0),
        direction=(0.0, 0.0, 1.0),
        axis_u=(0.5, 0.0, 0.0),
        axis_v=(0.0, 0.3, 0.0),
    )
    cam = look_at_camera((0.0, 2.5, 4.0), (0.0, 0.5, 0.5), hfov_deg=70.0)
    scene = make_scene([wall, floor], [Material("/w", roughness=0.7)], lights=[panel], cameras=[cam])
    out = render(scene, device, shadow_samples=samples)
    floor_px = out.triangle_id >= 2
    assert floor_px.sum() > 500
    assert np.all(out.view.visibility[..., 0][floor_px] == 1.0)
