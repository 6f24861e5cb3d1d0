"""The error bound of a point on each triangle, read by the rays that leave it.

A hit point interpolated from a triangle's float32 corners, and the intersection test of a
ray that leaves it, err by a few ulps of the corners' largest coordinate ``M`` and of the
triangle's extent ``E`` (``trace/offset.py`` says how, and how far a ray's origin moves
because of it).  ``corner_bound`` is that magnitude, ``max(M, EXTENT_WEIGHT * E)``, and
``DeviceScene`` keeps it for every triangle (``SceneGPU.triangle_bound``), computed on
the device by ``triangle_bounds`` when the points are uploaded and whenever an update
moves them: a ray's origin reads one float where it read its triangle's three indices
and three corners (a random fetch; 12-15% of the primary shadow kernel's time on
Suzanne and the smoke test).  The same operations on the same corners (no addition, so
nothing a compiler could fuse): the same bits wherever it is computed.
"""

from __future__ import annotations

import warp as wp

#: How the triangle's extent weighs in the bound (``trace/offset.py``: 128 / 16 ulps).
EXTENT_WEIGHT = wp.constant(8.0)


@wp.func
def _max_abs(v: wp.vec3) -> float:
    return wp.max(wp.abs(v[0]), wp.max(wp.abs(v[1]), wp.abs(v[2])))


@wp.func
def corner_bound(p0: wp.vec3, p1: wp.vec3, p2: wp.vec3) -> float:
    """``max(M, EXTENT_WEIGHT * E)`` of the triangle with corners ``p0, p1, p2``: ``M`` the
    largest magnitude of a coordinate, ``E`` the largest of an edge's."""
    m = wp.max(_max_abs(p0), wp.max(_max_abs(p1), _max_abs(p2)))
    e = wp.max(_max_abs(p1 - p0), wp.max(_max_abs(p2 - p0), _max_abs(p2 - p1)))
    return wp.max(m, EXTENT_WEIGHT * e)


@wp.kernel(enable_backward=False)
def triangle_bounds_kernel(
    points: wp.array(dtype=wp.vec3), indices: wp.array(dtype=wp.int32), bounds: wp.array(dtype=wp.float32)
):
    tri = wp.tid()
    k = 3 * tri
    bounds[tri] = corner_bound(points[indices[k]], points[indices[k + 1]], points[indices[k + 2]])


def triangle_bounds(points: wp.array, indices: wp.array, bounds: wp.array | None = None) -> wp.array:
    """Every triangle's ``corner_bound`` (``indices``: three a triangle) into ``bounds``
    (made, on the points' device, when None; one float a triangle) and return it."""
    count = indices.shape[0] // 3
    if bounds is None:
        bounds = wp.empty(max(count, 1), dtype=wp.float32, device=points.device)
    if count > 0:
        wp.launch(triangle_bounds_kernel, dim=count, inputs=[points, indices, bounds], device=points.device)
    return bounds
