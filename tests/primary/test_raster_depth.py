"""View depth of both primary paths against float64 references: a tilted plane
(analytic) and a tessellated sphere (exact float64 hit on its flat triangles)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Camera, Material

W, H = 64, 48


def _camera(near: float = 0.05) -> Camera:
    """At the origin looking down -Z; tan(half hfov) = 1 exactly."""
    return Camera("/cam", np.eye(4), 50.0, 100.0, 75.0, near, 1.0e4)


def _closest_hits(origin: np.ndarray, dirs: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """float64 Moller-Trumbore: nearest t over all triangles per ray (inf = miss)."""
    d = dirs.reshape(-1, 3)[:, None, :]
    p0, p1, p2 = (tris[None, :, k, :] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    pv = np.cross(d, e2)
    det = np.einsum("rtk,rtk->rt", np.broadcast_to(e1, pv.shape), pv)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        tv = origin[None, None, :] - p0
        u = np.einsum("rtk,rtk->rt", np.broadcast_to(tv, pv.shape), pv) * inv
        qv = np.cross(np.broadcast_to(tv, pv.shape), np.broadcast_to(e1, pv.shape))
        v = np.einsum("rtk,rtk->rt", np.broadcast_to(d, qv.shape), qv) * inv
        t = np.einsum("rtk,rtk->rt", np.broadcast_to(e2, qv.shape), qv) * inv
    ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(ok, t, np.inf).min(axis=1).reshape(dirs.shape[:2])


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_plane_depth_is_analytic(device: str, path: str, render, rays) -> None:
    n = np.array([0.3, 0.2, 1.0])
    n /= np.linalg.norm(n)
    p0 = np.array([0.0, 0.0, -5.0])
    e1 = np.cross(n, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    scene = make_scene([quad(tuple(p0 - 20 * e1 - 20 * e2), tuple(40 * e1), tuple(40 * e2))], [Material("m")])
    cam = _camera()
    gb = render(scene, cam, W, H, device, path)
    origin, d = rays(cam, W, H)
    expected = (n @ (p0 - origin)) / (d @ n)
    depth = gb.depth.numpy()
    assert (gb.triangle_id.numpy() >= 0).all()
    np.testing.assert_array_less(np.abs(depth - expected) / expected, 1e-5)


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_sphere_depth_matches_float64_mesh_hits(device: str, path: str, render, rays) -> None:
    sphere = uv_sphere((0.2, -0.1, -4.0), 1.3, rings=12, segments=24)
    scene = make_scene([sphere], [Material("m")])
    cam = look_at_camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), hfov_deg=50.0)
    gb = render(scene, cam, W, H, device, path)
    origin, d = rays(cam, W, H)
    expected = _closest_hits(origin, d, sphere.points.astype(np.float64)[sphere.indices])
    hit = np.isfinite(expected)
    inner = ndimage.binary_erosion(hit, iterations=1)
    assert inner.sum() > 300
    depth = gb.depth.numpy()
    assert np.isfinite(depth[inner]).all()
    rel = np.abs(depth[inner] - expected[inner]) / expected[inner]
    assert rel.max() <= 1e-5
    # Outside the silhouette's one-pixel border the hit masks agree exactly.
    border = hit ^ inner | (ndimage.binary_dilation(hit) & ~hit)
    np.testing.assert_array_equal((gb.triangle_id.numpy() >= 0)[~border], hit[~border])
