"""The ray-origin offset (Ray Tracing Gems ch. 6, scale-aware) at scene scales from
1e-3 to 1e4: rays leaving a tessellated plane never re-hit it (no acne) and always
hit a parallel occluder a thousandth of the scene size above it (no leaking)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from warp_hybrid.trace.offset import offset_ray_origin


@wp.kernel
def _cast_from_offsets(
    mesh: wp.uint64,
    points: wp.array(dtype=wp.vec3),
    dirs: wp.array(dtype=wp.vec3),
    normal: wp.vec3,
    scale: float,
    origins: wp.array(dtype=wp.vec3),
    hit_t: wp.array(dtype=wp.float32),
):
    i = wp.tid()
    o = offset_ray_origin(points[i], normal, scale)
    origins[i] = o
    q = wp.mesh_query_ray(mesh, o, dirs[i], wp.inf)
    hit_t[i] = -1.0
    if q.result:
        hit_t[i] = wp.length(o + dirs[i] * q.t - points[i])


def _grid(center: np.ndarray, u: np.ndarray, v: np.ndarray, size: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A jittered n x n grid of coplanar triangles (points, indices)."""
    rng = np.random.default_rng(5)
    s, t = np.meshgrid(np.linspace(-0.5, 0.5, n + 1), np.linspace(-0.5, 0.5, n + 1))
    j = rng.uniform(-0.3, 0.3, (2,) + s.shape) / n
    j[:, [0, -1], :] = 0.0
    j[:, :, [0, -1]] = 0.0
    s, t = s + j[0], t + j[1]
    pts = center + size * (s[..., None] * u + t[..., None] * v)
    idx = []
    for r in range(n):
        for c in range(n):
            a, b, d, e = r * (n + 1) + c, r * (n + 1) + c + 1, (r + 1) * (n + 1) + c, (r + 1) * (n + 1) + c + 1
            idx += [(a, d, b), (b, d, e)]
    return pts.reshape(-1, 3), np.asarray(idx)


@pytest.mark.parametrize("scale", [1.0e-3, 1.0, 1.0e4])
def test_offset_avoids_acne_and_leaks_at_any_scale(device: str, scale: float) -> None:
    normal = np.array([0.2, 1.0, -0.3])
    normal /= np.linalg.norm(normal)
    u = np.cross(normal, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(u, normal)
    size = 10.0 * scale
    gap = 1.0e-3 * size
    # a receiver across the origin (coordinates from ~0 to ~6 scale) and an occluder above it
    recv_pts, recv_idx = _grid(np.array([1.0, 0.5, -0.5]) * scale, u, v, size, 16)
    occ_pts, occ_idx = _grid(np.array([1.0, 0.5, -0.5]) * scale + gap * normal, u, v, 1.5 * size, 9)
    pts = np.concatenate([recv_pts, occ_pts]).astype(np.float32)
    idx = np.concatenate([recv_idx, occ_idx + len(recv_pts)]).astype(np.int32)
    mesh = wp.Mesh(
        points=wp.array(pts, dtype=wp.vec3, device=device),
        indices=wp.array(idx.reshape(-1), dtype=wp.int32, device=device),
    )
    S = float(np.abs(pts).max())  # the largest coordinate: a conservative bound of every hit here

    # ray starts: barycentric points of receiver triangles (as the G-buffer computes them)
    rng = np.random.default_rng(11)
    tri = rng.integers(0, len(recv_idx), 4000)
    b = rng.dirichlet((1.0, 1.0, 1.0), len(tri)).astype(np.float32)
    p32 = recv_pts.astype(np.float32)[recv_idx[tri]]
    starts = (p32[:, 0] * b[:, :1] + p32[:, 1] * b[:, 1:2] + p32[:, 2] * b[:, 2:3]).astype(np.float32)
    # directions from 0.5 to 90 degrees above the plane
    elev = np.radians(rng.uniform(0.5, 90.0, len(tri)))
    az = rng.uniform(0.0, 2.0 * math.pi, len(tri))
    dirs = np.sin(elev)[:, None] * normal + np.cos(elev)[:, None] * (np.cos(az)[:, None] * u + np.sin(az)[:, None] * v)

    origins = wp.zeros(len(tri), dtype=wp.vec3, device=device)
    hit_t = wp.zeros(len(tri), dtype=wp.float32, device=device)
    wp.launch(
        _cast_from_offsets,
        dim=len(tri),
        inputs=[
            mesh.id,
            wp.array(starts, dtype=wp.vec3, device=device),
            wp.array(dirs.astype(np.float32), dtype=wp.vec3, device=device),
            wp.vec3(*normal.tolist()),
            S,
            origins,
            hit_t,
        ],
        device=device,
    )
    t = hit_t.numpy().astype(np.float64)
    expected = gap / np.sin(elev)
    assert np.all(t > 0.0), "every ray must hit the occluder (a miss is a leak)"
    assert np.all(np.abs(t / expected - 1.0) < 0.1), "a hit short of the occluder is acne"
    lift = np.einsum("ij,j->i", origins.numpy().astype(np.float64) - starts, normal)
    assert np.all(lift > 0.0) and np.all(lift < 0.05 * gap)
