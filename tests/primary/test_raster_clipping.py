"""Triangles crossing the near plane or reaching far outside the screen are clipped,
not dropped, and keep their exact depth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from warp_hybrid.scene.authoring.builders import MeshInput, make_scene
from warp_hybrid.scene.model import Camera, Material

W, H = 64, 48


def _camera(near: float) -> Camera:
    return Camera("/cam", np.eye(4), 50.0, 100.0, 75.0, near, 1.0e4)


def _floor(half: float, near_z: float, far_z: float) -> MeshInput:
    pts = np.array([[-half, -1.0, near_z], [half, -1.0, near_z], [0.0, -1.0, far_z]], np.float32)
    return MeshInput(pts, np.array([[0, 1, 2]], np.int32))


def _floor_depth(rays, cam: Camera) -> np.ndarray:
    _, d = rays(cam, W, H)
    with np.errstate(divide="ignore"):
        return np.where(d[..., 1] < 0, -1.0 / d[..., 1], np.inf)


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_triangle_straddling_the_near_plane(device: str, path: str, render, rays) -> None:
    """A floor triangle with a corner behind the camera: what lies beyond the near plane
    is drawn with the plane's depth, what lies in front of it is cut away."""
    cam = _camera(near=2.0)
    scene = make_scene([_floor(1000.0, 5.0, -5000.0)], [Material("m")])
    gb = render(scene, cam, W, H, device, path)
    expected_depth = _floor_depth(rays, cam)
    hit = gb.triangle_id.numpy() >= 0
    depth = gb.depth.numpy()
    np.testing.assert_array_less(np.abs(depth[hit] - expected_depth[hit]) / expected_depth[hit], 1e-5)
    assert (expected_depth[hit] >= 2.0 * (1 - 1e-5)).all()
    # Rows whose floor point is nearer than the near plane are empty, the rest covered
    # (the triangle is wide enough that its slanted sides stay out of view).
    near_rows = (expected_depth < 2.0 * 0.999).all(axis=1)
    far_rows = (expected_depth > 2.0 * 1.001).all(axis=1) & np.isfinite(expected_depth).all(axis=1)
    assert near_rows.sum() >= 5 and far_rows.sum() >= 10
    assert not hit[near_rows].any()
    assert hit[far_rows].all()


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_huge_triangles_are_clipped_to_the_guard_band(device: str, path: str, render, rays) -> None:
    """A screen-filling triangle far beyond the fixed-point range, and a huge floor
    crossing the near plane: exact coverage (the horizon falls between rows 23 and 24)."""
    cam = _camera(near=0.01)
    corners = np.array([[-1e7, -1e7, -3.0], [1e7, -1e7, -3.0], [0.0, 1e7, -3.0]], np.float32)
    wall = MeshInput(corners, np.array([[0, 1, 2]], np.int32))
    gb = render(make_scene([wall], [Material("m")]), cam, W, H, device, path)
    assert (gb.triangle_id.numpy() == 0).all()
    np.testing.assert_allclose(gb.depth.numpy(), 3.0, rtol=1e-5)

    gb = render(make_scene([_floor(1e3, 1e3, -1e3)], [Material("m")]), cam, W, H, device, path)
    hit = gb.triangle_id.numpy() >= 0
    assert not hit[:24].any() and hit[24:].all()
    expected_depth = _floor_depth(rays, cam)
    # float32 corners 1e3 away from hits at depth ~1.4..64 leave ~1e3 * 2^-24 of slack.
    np.testing.assert_array_less(np.abs(gb.depth.numpy()[24:] - expected_depth[24:]) / expected_depth[24:], 1e-4)


def test_near_plane_cut_matches_the_ray_cast(device: str, render) -> None:
    """Both paths clip at the same near plane: coverage agrees except on the cut line."""
    cam = _camera(near=2.0)
    scene = make_scene([_floor(1000.0, 5.0, -5000.0)], [Material("m")])
    a = render(scene, cam, W, H, device, "raster").triangle_id.numpy() >= 0
    b = render(scene, cam, W, H, device, "raycast").triangle_id.numpy() >= 0
    edge = ndimage.binary_dilation(b) & ~ndimage.binary_erosion(b)
    np.testing.assert_array_equal(a[~edge], b[~edge])
