"""Implicit prims (Cube, Sphere, Cone, Cylinder, Capsule, Plane) tessellated from their
schema attributes: analytic depth, extents, transforms, materials and displayColor."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, UsdGeom
from render_kit import add_camera, pixel_rays, render_aovs
from usd_stage_kit import bind, new_stage, preview_material, save_and_load

from warp_hybrid.scene.usd.implicit import RINGS, SEGMENTS


def _range(scene, path):
    return next(m for m in scene.meshes if m.prim_path == path)


def _bounds(scene, path):
    r = _range(scene, path)
    pts = scene.points[r.first_point : r.first_point + r.point_count]
    return pts.min(axis=0), pts.max(axis=0)


@pytest.mark.parametrize("primary", ["raycast", "raster"])
def test_unit_cube_has_the_analytic_depth(tmp_path, device, primary):
    stage, path = new_stage(tmp_path)
    cube = UsdGeom.Cube.Define(stage, "/World/Box")
    cube.CreateSizeAttr(1.0)
    cube.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, -1.0))  # front face at z = -0.5
    add_camera(stage, 5.0)
    scene = save_and_load(stage, path)
    assert _range(scene, "/World/Box").triangle_count == 12
    depth = render_aovs(scene, device=device, primary=primary)["depth"]
    rays = pixel_rays(48, 36)
    front = (np.abs(rays[..., 0] * 5.5) < 0.49) & (np.abs(rays[..., 1] * 5.5) < 0.49)
    assert front.sum() > 50
    np.testing.assert_allclose(depth[front], 5.5, rtol=1e-5)
    outside = (np.abs(rays[..., 0] * 5.0) > 0.51) | (np.abs(rays[..., 1] * 5.0) > 0.51)  # misses even the back
    assert np.isinf(depth[outside]).all()


def test_sphere_of_radius_r_has_the_analytic_depth(tmp_path, device):
    r, d = 0.75, 4.0
    stage, path = new_stage(tmp_path)
    ball = UsdGeom.Sphere.Define(stage, "/World/Ball")
    ball.CreateRadiusAttr(r)
    add_camera(stage, d)
    scene = save_and_load(stage, path)
    assert _range(scene, "/World/Ball").triangle_count == 2 * SEGMENTS * (RINGS - 1)
    depth = render_aovs(scene, device=device, primary="raycast")["depth"]
    # Ray o + t dir, o = (0, 0, d), dir = (x, y, -1): |o + t dir|^2 = r^2.
    rays = pixel_rays(48, 36)
    a = (rays**2).sum(axis=-1)
    b = -2.0 * d
    c = d * d - r * r
    disc = b * b - 4 * a * c
    t = (-b - np.sqrt(np.maximum(disc, 0.0))) / (2 * a)
    hit_point = rays * t[..., None] + np.array([0.0, 0.0, d])
    cos_incidence = (-(rays / np.sqrt(a)[..., None]) * hit_point / r).sum(axis=-1)
    facing = (disc > 0) & (cos_incidence > 0.5)
    assert facing.sum() > 100
    # The mesh lies inside the sphere by at most r (1 - cos^2(3.75 deg)) (implicit.py): along a ray
    # that meets the surface at incidence cos >= 0.5, at most twice that deeper.
    sag = r * (1 - math.cos(math.pi / SEGMENTS) ** 2)
    err = depth[facing] - t[facing]
    assert err.min() > -1e-4 and err.max() < 2 * sag + 1e-4
    assert np.abs(err).min() < 1e-3 * r  # near the vertices the mesh meets the sphere
    assert np.isinf(depth[disc < -0.05]).all()  # well off the silhouette: background


def test_shapes_follow_their_schema_attributes(tmp_path):
    stage, path = new_stage(tmp_path)
    cone = UsdGeom.Cone.Define(stage, "/World/Cone")
    cone.CreateRadiusAttr(0.5)
    cone.CreateHeightAttr(2.0)
    cone.CreateAxisAttr("Y")
    cyl = UsdGeom.Cylinder.Define(stage, "/World/Cyl")
    cyl.CreateAxisAttr("X")
    cyl.CreateHeightAttr(3.0)
    cyl.CreateRadiusAttr(0.25)
    UsdGeom.Capsule.Define(stage, "/World/Pill")  # fallbacks: radius 0.5, height 1, axis Z
    plane = UsdGeom.Plane.Define(stage, "/World/Floor")
    plane.CreateAxisAttr("Y")
    plane.CreateWidthAttr(4.0)
    plane.CreateLengthAttr(6.0)
    tapered = UsdGeom.Cylinder_1.Define(stage, "/World/Taper")
    tapered.CreateRadiusTopAttr(0.0)
    tapered.CreateRadiusBottomAttr(1.0)
    scene = save_and_load(stage, path)
    lo, hi = _bounds(scene, "/World/Cone")
    np.testing.assert_allclose(lo, (-0.5, -1.0, -0.5), atol=1e-6)
    np.testing.assert_allclose(hi, (0.5, 1.0, 0.5), atol=1e-6)
    r = _range(scene, "/World/Cone")
    apex = scene.points[r.first_point : r.first_point + r.point_count]
    assert np.isclose(apex[:, 1].max(), 1.0) and np.allclose(apex[apex[:, 1] > 0.999][:, [0, 2]], 0, atol=1e-6)
    lo, hi = _bounds(scene, "/World/Cyl")
    np.testing.assert_allclose(lo, (-1.5, -0.25, -0.25), atol=1e-6)
    np.testing.assert_allclose(hi, (1.5, 0.25, 0.25), atol=1e-6)
    lo, hi = _bounds(scene, "/World/Pill")
    np.testing.assert_allclose(lo, (-0.5, -0.5, -1.0), atol=1e-6)
    np.testing.assert_allclose(hi, (0.5, 0.5, 1.0), atol=1e-6)
    lo, hi = _bounds(scene, "/World/Floor")
    np.testing.assert_allclose(lo, (-2.0, 0.0, -3.0), atol=1e-6)
    np.testing.assert_allclose(hi, (2.0, 0.0, 3.0), atol=1e-6)
    floor = _range(scene, "/World/Floor")
    p = scene.points[scene.indices[floor.first_triangle]].astype(np.float64)
    assert np.cross(p[1] - p[0], p[2] - p[0])[1] > 0  # counter-clockwise seen from +Y, the axis
    assert scene.materials[scene.triangle_material[floor.first_triangle]].double_sided  # Plane's fallback
    lo, hi = _bounds(scene, "/World/Taper")
    np.testing.assert_allclose(lo, (-1.0, -1.0, -1.0), atol=1e-6)
    np.testing.assert_allclose(hi, (1.0, 1.0, 1.0), atol=1e-6)
    # Every triangle faces away from the shape's centre (all are convex and centred).
    for name in ("/World/Cone", "/World/Cyl", "/World/Pill", "/World/Taper"):
        r = _range(scene, name)
        tri = scene.points[scene.indices[r.first_triangle : r.first_triangle + r.triangle_count]].astype(np.float64)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        assert ((n * tri.mean(axis=1)).sum(axis=1) > 0).all(), name
    assert not [w for w in scene.warnings if "not supported" in w]


def test_implicit_prims_take_transforms_materials_and_display_color(tmp_path):
    stage, path = new_stage(tmp_path)
    parent = UsdGeom.Xform.Define(stage, "/World/G")
    parent.AddTranslateOp().Set(Gf.Vec3d(10.0, 0.0, 0.0))
    parent.AddScaleOp().Set(Gf.Vec3f(2.0, 2.0, 2.0))
    ball = UsdGeom.Sphere.Define(stage, "/World/G/Ball")
    ball.CreateDisplayColorAttr([Gf.Vec3f(0.1, 0.6, 0.2)])
    red, _ = preview_material(stage, "/World/Looks/Red", diffuseColor=(1.0, 0.0, 0.0))
    bind(UsdGeom.Cube.Define(stage, "/World/G/Box"), red)
    scene = save_and_load(stage, path)
    lo, hi = _bounds(scene, "/World/G/Ball")
    np.testing.assert_allclose(lo, (8.0, -2.0, -2.0), atol=1e-5)
    np.testing.assert_allclose(hi, (12.0, 2.0, 2.0), atol=1e-5)
    ball_material = scene.materials[scene.triangle_material[_range(scene, "/World/G/Ball").first_triangle]]
    np.testing.assert_allclose(ball_material.diffuse, (0.1, 0.6, 0.2), rtol=1e-6)
    box_material = scene.materials[scene.triangle_material[_range(scene, "/World/G/Box").first_triangle]]
    assert box_material.name == "/World/Looks/Red"
    lo, hi = _bounds(scene, "/World/G/Box")
    np.testing.assert_allclose(hi - lo, (4.0, 4.0, 4.0), atol=1e-5)  # size 2 (fallback) scaled by 2
