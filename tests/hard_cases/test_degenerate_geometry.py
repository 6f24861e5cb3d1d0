"""Zero-area and sliver triangles, coincident coplanar faces (a deterministic winner,
no noise), the camera inside an object, triangles across the near plane and a far/near
ratio of 1e6 (issue 10, cases 6 and 8)."""

from __future__ import annotations

import numpy as np
import pytest
from hard_kit import render

from warp_hybrid.scene.authoring.builders import MeshInput, look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Light, LightKind, Material

SUN = Light(LightKind.DISTANT, "/sun", (1.0, 1.0, 1.0), direction=(-0.2, -1.0, -0.5))


def test_zero_area_and_sliver_triangles_render_finite(device):
    pts = np.array(
        [
            [0, 0, 0],
            [1, 0, 0],
            [2, 0, 0],  # collinear
            [0, 1, 0],
            [0, 1, 0],
            [1, 1, 0],  # repeated point
            [-1, 0, -0.5],
            [1, 1e-6, -0.5],
            [1, 0, -0.5],  # a 1e-6 sliver
            [-1, -1, -1],
            [1, -1, -1],
            [1, 1, -1],
            [-1, 1, -1],
        ],
        np.float32,
    )
    idx = np.array([[0, 1, 2], [3, 4, 5], [7, 7, 7], [6, 7, 8], [9, 10, 11], [9, 11, 12]], np.int32)
    cam = look_at_camera((0.2, 0.3, 3.0), (0.2, 0.3, 0.0), hfov_deg=60.0)
    scene = make_scene([MeshInput(pts, idx)], [Material("/m", diffuse=(0.5, 0.5, 0.5))], lights=[SUN], cameras=[cam])
    for primary in ("raster", "raycast"):
        out = render(scene, device, primary=primary)
        assert np.isfinite(out.color).all() and (out.color >= 0).all()
        hit = out.triangle_id >= 0
        assert np.isfinite(out.position[hit]).all()
        assert set(np.unique(out.triangle_id[hit])) <= {3, 4, 5}  # the degenerate ones are never hit


@pytest.mark.parametrize("primary", ["raster", "raycast"])
def test_coincident_faces_have_one_deterministic_winner(device, primary):
    red = quad((-1.0, -1.0, 0.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), 0)
    blue = quad((-1.0, -1.0, 0.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), 1)  # the very same triangles
    cam = look_at_camera((0.3, 0.2, 2.0), (0.0, 0.0, 0.0), hfov_deg=50.0)
    mats = [Material("/red", diffuse=(1, 0, 0)), Material("/blue", diffuse=(0, 0, 1))]
    scene = make_scene([red, blue], mats, lights=[SUN], cameras=[cam])
    a = render(scene, device, primary=primary)
    b = render(scene, device, primary=primary)
    hit = a.triangle_id >= 0
    np.testing.assert_array_equal(a.triangle_id, b.triangle_id)
    np.testing.assert_array_equal(a.view.image, b.view.image)
    if primary == "raster":
        assert np.all(a.triangle_id[hit] < 2)  # ties go to the smaller id: red, everywhere


def test_camera_inside_a_closed_object(device):
    """From inside a sphere every pixel sees its inner wall at the analytic distance."""
    cam = look_at_camera((0.1, -0.05, 0.0), (0.1, -0.05, -1.0), hfov_deg=70.0)
    ball = uv_sphere((0.0, 0.0, 0.0), 2.0, rings=48, segments=96)
    lamp = Light(LightKind.SPHERE, "/lamp", (5.0, 5.0, 5.0), position=(0.0, 0.5, 0.0), radius=0.05)
    scene = make_scene([ball], [Material("/m")], lights=[lamp], cameras=[cam])
    for primary in ("raster", "raycast"):
        out = render(scene, device, primary=primary)
        assert np.all(out.triangle_id >= 0)
        r = np.linalg.norm(out.position.astype(np.float64), axis=-1)
        np.testing.assert_allclose(r, 2.0, rtol=2e-3)  # the tessellation's sagitta
        assert np.isfinite(out.color).all() and (out.view.visibility == 1.0).all()


def test_triangle_across_the_near_plane_and_a_far_near_ratio_of_1e6(device):
    """A floor running from behind the camera to 1e3 away (crossing the near plane) and
    a far wall at 900, seen with near 1e-3 and far 1e3: raster equals ray cast, and
    the depth matches the analytic plane."""
    near, far = 1.0e-3, 1.0e3
    floor = quad((-500.0, -1.0, 10.0), (1000.0, 0.0, 0.0), (0.0, 0.0, -1000.0), 0)
    wall = quad((-500.0, -1.0, -900.0), (1000.0, 0.0, 0.0), (0.0, 400.0, 0.0), 0)
    cam = look_at_camera((0.0, 0.0, 0.0), (0.0, -0.2, -1.0), hfov_deg=60.0, near=near, far=far)
    scene = make_scene([floor, wall], [Material("/m")], lights=[SUN], cameras=[cam])
    raster = render(scene, device, primary="raster")
    cast = render(scene, device, primary="raycast")
    np.testing.assert_array_equal(raster.triangle_id >= 0, cast.triangle_id >= 0)
    hit = raster.triangle_id >= 0
    np.testing.assert_allclose(raster.view.depth[hit], cast.view.depth[hit], rtol=1e-5)
    on_floor = hit & (raster.triangle_id < 2)
    y = raster.position[on_floor][:, 1].astype(np.float64)
    assert np.all(np.abs(y + 1.0) <= 1e-5 * np.maximum(raster.view.depth[on_floor], 1.0))  # on the analytic plane
    assert raster.view.depth[hit].max() > 800.0 and np.all(raster.view.depth[hit] > 0)
