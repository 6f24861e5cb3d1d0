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

#: ``sample_steps``' result: the rows ddx, ddy.
SampleSteps = wp.types.matrix(shape=(2, 3), dtype=wp.float32)


@wp.func(inline=True)
def sample_steps(cam: CameraGPU) -> SampleSteps:
    """How a camera ray's direction moves for one sample step right (row 0) and one down
    (row 1): one pixel, unless the frame is supersampled (``CameraGPU.sample_step``)."""
    spread = sample_spread(cam)
    ddx = cam.right * spread[0]
    ddy = cam.up * (-spread[1])
    return SampleSteps(ddx[0], ddx[1], ddx[2], ddy[0], ddy[1], ddy[2])


@wp.func(inline=True)
def pixel_footprint(scene: SceneGPU, cam: CameraGPU, tri: int, d: wp.vec3) -> wp.vec4:
    """uv footprint (du/dx, dv/dx, du/dy, dv/dy) on triangle ``tri`` of the pixel sample
    whose camera ray is ``d``: the ray differentials of one sample step right and down
    (``sample_steps``)."""
    steps = sample_steps(cam)
    return uv_footprint(scene, tri, cam.origin, d, steps[0], steps[1])


#: C++ statements: the ray ``o + t d`` against the plane of the triangle ``p0, p1, p2``
#: (Moller-Trumbore) without a branch: ``rt_t``; ``rt_bu``, ``rt_bv``, Warp's barycentrics
#: (the weights of ``p0`` and ``p1``) clamped onto the triangle; ``rt_ok``, false where the
#: ray is parallel to the plane (then t = 0 and both weights 1/3).  One Warp operation a
#: statement (as ``camera.CAMERA_RAY_CPP``): written once for ``ray_triangle``,
#: ``exact_hit`` and the resolve's row loop (``kernels.py``), the same bits in each.
RAY_TRIANGLE_CPP = """
const wp::vec3 rt_e1 = wp::sub(p1, p0);
const wp::vec3 rt_e2 = wp::sub(p2, p0);
const wp::vec3 rt_pv = wp::cross(d, rt_e2);
const float rt_det = wp::dot(rt_e1, rt_pv);
const bool rt_ok = !(rt_det == 0.0f);
const float rt_inv = wp::div(1.0f, rt_det);
const wp::vec3 rt_tv = wp::sub(o, p0);
const float rt_b1 = wp::mul(wp::dot(rt_tv, rt_pv), rt_inv);
const wp::vec3 rt_qv = wp::cross(rt_tv, rt_e1);
const float rt_b2 = wp::mul(wp::dot(d, rt_qv), rt_inv);
const float rt_hit_t = wp::mul(wp::dot(rt_e2, rt_qv), rt_inv);
const float rt_c1 = wp::max(rt_b1, 0.0f);
const float rt_c2 = wp::max(rt_b2, 0.0f);
const float rt_s = wp::add(rt_c1, rt_c2);
const bool rt_over = rt_s > 1.0f;
const float rt_w1 = rt_over ? wp::div(rt_c1, rt_s) : rt_c1;
const float rt_w2 = rt_over ? wp::div(rt_c2, rt_s) : rt_c2;
const float rt_third = wp::div(1.0f, 3.0f);
const float rt_t = rt_ok ? rt_hit_t : 0.0f;
const float rt_bu = rt_ok ? wp::sub(wp::sub(1.0f, rt_w1), rt_w2) : rt_third;
const float rt_bv = rt_ok ? rt_w1 : rt_third;
"""

#: C++ statements: ``RAY_TRIANGLE_CPP`` from the camera origin ``o``, then ``eh_t``, the hit's
#: view depth: ``rt_t``, or where the ray grazes the plane (parallel, or no hit in front)
#: the depth along ``fwd`` (the camera's forward axis) of the barycentric point.
EXACT_HIT_CPP = (
    RAY_TRIANGLE_CPP
    + """
const bool eh_grazing = !rt_ok || !(rt_t > 0.0f);
const wp::vec3 eh_p = wp::add(
    wp::add(wp::mul(p0, rt_bu), wp::mul(p1, rt_bv)), wp::mul(p2, wp::sub(wp::sub(1.0f, rt_bu), rt_bv))
);
const float eh_t = eh_grazing ? wp::dot(wp::sub(eh_p, o), fwd) : rt_t;
"""
)


@wp.func_native(RAY_TRIANGLE_CPP + "return wp::vec4(rt_t, rt_bu, rt_bv, rt_ok ? 1.0f : 0.0f);")
def ray_triangle(o: wp.vec3, d: wp.vec3, p0: wp.vec3, p1: wp.vec3, p2: wp.vec3) -> wp.vec4:
    """Intersect the ray o + t d with the plane of triangle (p0, p1, p2).

    Returns (t, bu, bv, ok) with Warp's barycentric convention (bu weighs p0, bv weighs
    p1), barycentrics clamped onto the triangle; ok = 0 when the ray is parallel
    (``RAY_TRIANGLE_CPP``)."""
    ...


@wp.func_native(EXACT_HIT_CPP + "return wp::vec3(eh_t, rt_bu, rt_bv);")
def _exact_hit(o: wp.vec3, fwd: wp.vec3, d: wp.vec3, p0: wp.vec3, p1: wp.vec3, p2: wp.vec3) -> wp.vec3:
    """(t, bu, bv) of the ray ``o + t d`` on the triangle ``p0, p1, p2`` (``EXACT_HIT_CPP``)."""
    ...


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
    return _exact_hit(cam.origin, cam.forward, d, pts[0], pts[1], pts[2])
