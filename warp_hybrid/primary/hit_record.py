"""The hit record of a camera ray: exact ray-triangle hits and the pixel's footprint
(``@wp.func``, shared by both primary paths).

Both paths intersect the pixel's camera ray with the triangle they found *exactly from
the camera origin* (``exact_hit``), so their depths and barycentrics come from the same
arithmetic and differ only in which triangle each picked.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU, sample_spread
from ..core.scene_gpu import SceneGPU
from ..scene.device.surface import uv_footprint


@wp.func(inline=True)
def pixel_footprint(scene: SceneGPU, cam: CameraGPU, tri: int, d: wp.vec3) -> wp.vec4:
    """uv footprint (du/dx, dv/dx, du/dy, dv/dy) on triangle ``tri`` of the pixel sample
    whose camera ray is ``d``: the ray differentials of one sample step right and down
    (one pixel, unless the frame is supersampled: ``CameraGPU.sample_step``)."""
    spread = sample_spread(cam)
    return uv_footprint(scene, tri, cam.origin, d, cam.right * spread[0], cam.up * (-spread[1]))


@wp.func(inline=True)
def ray_triangle(o: wp.vec3, d: wp.vec3, p0: wp.vec3, p1: wp.vec3, p2: wp.vec3) -> wp.vec4:
    """Intersect the ray o + t d with the plane of triangle (p0, p1, p2).

    Returns (t, bu, bv, ok) with Warp's barycentric convention (bu weighs p0, bv weighs
    p1), barycentrics clamped onto the triangle; ok = 0 when the ray is parallel."""
    e1 = p1 - p0
    e2 = p2 - p0
    pv = wp.cross(d, e2)
    det = wp.dot(e1, pv)
    if det == 0.0:
        return wp.vec4(0.0, 1.0 / 3.0, 1.0 / 3.0, 0.0)
    inv = 1.0 / det
    tv = o - p0
    b1 = wp.dot(tv, pv) * inv
    qv = wp.cross(tv, e1)
    b2 = wp.dot(d, qv) * inv
    t = wp.dot(e2, qv) * inv
    b1 = wp.max(b1, 0.0)
    b2 = wp.max(b2, 0.0)
    s = b1 + b2
    if s > 1.0:
        b1 = b1 / s
        b2 = b2 / s
    return wp.vec4(t, 1.0 - b1 - b2, b1, 1.0)


@wp.func(inline=True)
def triangle_points(scene: SceneGPU, tri: int) -> wp.mat33:
    """The triangle's corners as the rows of a matrix."""
    k = 3 * tri
    p0 = scene.points[scene.indices[k]]
    p1 = scene.points[scene.indices[k + 1]]
    p2 = scene.points[scene.indices[k + 2]]
    return wp.mat33(p0[0], p0[1], p0[2], p1[0], p1[1], p1[2], p2[0], p2[1], p2[2])


@wp.func(inline=True)
def exact_hit(scene: SceneGPU, cam: CameraGPU, tri: int, d: wp.vec3) -> wp.vec3:
    """(t, bu, bv) of camera ray ``d`` (unit forward component, so t is the view depth)
    on triangle ``tri``, intersected exactly from the camera origin."""
    pts = triangle_points(scene, tri)
    h = ray_triangle(cam.origin, d, pts[0], pts[1], pts[2])
    t = h[0]
    if h[3] == 0.0 or not (t > 0.0):
        # Grazing: the ray runs (numerically) in the triangle's plane.
        p = pts[0] * h[1] + pts[1] * h[2] + pts[2] * (1.0 - h[1] - h[2])
        t = wp.dot(p - cam.origin, cam.forward)
    return wp.vec3(t, h[1], h[2])
