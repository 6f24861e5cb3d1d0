"""A ground plane 1e7 times larger than the view, seen from just above it: its
triangles cross a tiny near plane and leave the guard band by far, and must still be
drawn exactly (the clipping runs in float64: float32 cut points on the quad's diagonal,
whose ends are thousands of units away, fell behind the camera and the floor vanished)."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Material

W, H = 80, 60


@pytest.mark.parametrize("eye", [(1.0e-4, 1.0e-3, 2.0e-4), (-2.0e-4, 1.0e-3, 1.0e-4), (0.0, 1.0e-3, 3.0e-4)])
def test_huge_ground_seen_from_very_close_matches_the_ray_cast(device: str, render, overdraw, rays, eye) -> None:
    """A 1e4 x 1e4 quad at y = 0 centred under a camera 1e-3 above it (its diagonal
    passes within 3e-4 of the camera), near plane 1e-5.  The camera looks steeply down
    so every pixel ray's largest component is along y: only then is
    ``wp.mesh_query_ray`` (float32, relative to corners 7e3 away) exact enough to be
    the reference."""
    ground = quad((-5.0e3, 0.0, 5.0e3), (1.0e4, 0.0, 0.0), (0.0, 0.0, -1.0e4))
    target = (0.1 * eye[0], 0.0, 0.1 * eye[2])
    cam = look_at_camera(eye, target, hfov_deg=40.0, near=1.0e-5, far=1.0e4)
    scene = make_scene([ground], [Material("ground")], cameras=[cam])
    a = render(scene, cam, W, H, device, "raster")
    b = render(scene, cam, W, H, device, "raycast")
    assert (b.triangle_id.numpy() >= 0).all()
    assert (a.triangle_id.numpy() >= 0).all()
    # Watertight across the diagonal, which both clipped triangles cut.
    np.testing.assert_array_equal(overdraw(scene, cam, W, H, device), 1)

    origin, d = rays(cam, W, H)
    expected = -origin[1] / d[..., 1]  # view depth of the plane y = 0
    da, db = a.depth.numpy(), b.depth.numpy()
    np.testing.assert_array_less(np.abs(da - expected) / expected, 1e-5)
    np.testing.assert_array_less(np.abs(da - db) / db, 1e-4)
