"""Camera-space transform, projection and clipping of triangles (``@wp.func``).

Triangles wholly in front of the near plane and inside the guard band (+-``GUARD_PX``
pixels around the screen centre, which keeps fixed-point coordinates in range) are
projected from the shared per-vertex screen points.  The rare rest is clipped
(``raster_clipped``) against the near plane and the guard band into a polygon,
rasterized as a fan, in float64 from the world-space corners.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU
from ..core.native_rows import LAMBDA_HEADER_CPP
from ..core.scene_gpu import SceneGPU
from .coverage import RasterTarget, raster_triangle

GUARD_PX = wp.constant(262144.0)

# A clipped polygon has at most 3 + 5 vertices (near plane + 4 guard-band planes):
# float64 coordinates, and which corner (0..2) each vertex is, -1 for a cut point.
_vec9d = wp.types.vector(length=9, dtype=wp.float64)
_vec9i = wp.types.vector(length=9, dtype=wp.int32)


@wp.struct
class ProjectedPoints:
    """The scene's points transformed once per frame: ``camera`` in camera space (x
    right, y up, z = view depth), ``outcodes`` (``POINTS_CPP``'s ``wh_outcode``: where
    each lies against the view frustum) and, in front of the near plane, ``screen`` (x, y
    in pixels, view depth; a view of an allocation one point longer, as the coverage
    pass's CPU loop loads a point's three floats as four, ``cover_batch``)."""

    camera: wp.array(dtype=wp.vec3)
    outcodes: wp.array(dtype=wp.int32)
    screen: wp.array(dtype=wp.vec3)


#: An outcode's bits (``POINTS_CPP``'s ``wh_outcode``): beyond the near plane (z < near),
#: beyond the far plane, right of the right plane (x > tan_x z), left of the left one,
#: above the top one, below the bottom one; and in front of the near plane (z >= near, not the first bit's negation
#: where z is NaN).  A triangle whose corners share one of the first six bits lies wholly
#: outside the view (``OUTSIDE_BITS``, its trivial reject); it lies wholly in front of the
#: near plane where all three have ``IN_FRONT``.
BEHIND_NEAR, BEYOND_FAR, RIGHT_OF, LEFT_OF, ABOVE, BELOW, IN_FRONT = (1 << k for k in range(7))
OUTSIDE_BITS = wp.constant(BEHIND_NEAR | BEYOND_FAR | RIGHT_OF | LEFT_OF | ABOVE | BELOW)
IN_FRONT_BIT = wp.constant(IN_FRONT)


#: C++ (after ``LAMBDA_HEADER_CPP``), the one definition of a point's way to the screen, one
#: Warp operation a call in the order the Warp code had them: ``wh_to_camera(cam, p)``,
#: the point in camera space (x right, y up, z = view depth); ``wh_project(cam, c)``, a
#: camera-space point's (screen x, screen y, view depth); ``wh_outcode(c, near, far, tan_x,
#: tan_y)``, its bits against the view frustum (``OUTSIDE_BITS``, ``IN_FRONT_BIT``): each
#: per-point test of a triangle's trivial rejects, made once per point.  ``cam`` is any
#: ``CameraGPU``-like record.
POINTS_CPP = """
auto wh_to_camera = [&](const auto& cam, const wp::vec3& p) WH_INLINE -> wp::vec3 {
    const wp::vec3 d = wp::sub(p, cam.origin);
    return wp::vec3(wp::dot(d, cam.right), wp::dot(d, cam.up), wp::dot(d, cam.forward));
};
auto wh_project = [&](const auto& cam, const wp::vec3& c) WH_INLINE -> wp::vec3 {
    const float hw = wp::mul(0.5f, (float)cam.width), hh = wp::mul(0.5f, (float)cam.height);
    const float inv_z = wp::div(1.0f, c[2]);
    return wp::vec3(wp::add(hw, wp::mul(wp::mul(c[0], inv_z), wp::div(hw, cam.tan_x))),
                    wp::sub(hh, wp::mul(wp::mul(c[1], inv_z), wp::div(hh, cam.tan_y))), c[2]);
};
auto wh_outcode = [&](const wp::vec3& c, const float near, const float far, const float tan_x,
                      const float tan_y) WH_INLINE -> int {
    const float tz_x = wp::mul(tan_x, c[2]), tz_y = wp::mul(tan_y, c[2]);
""" + (
    "    return "
    + " | ".join(
        f"({test} ? {bit} : 0)"
        for test, bit in (
            ("c[2] < near", BEHIND_NEAR),
            ("c[2] > far", BEYOND_FAR),
            ("c[0] > tz_x", RIGHT_OF),
            ("wp::neg(c[0]) > tz_x", LEFT_OF),
            ("c[1] > tz_y", ABOVE),
            ("wp::neg(c[1]) > tz_y", BELOW),
            ("c[2] >= near", IN_FRONT),
        )
    )
    + ";\n};\n"
)


@wp.func_native(LAMBDA_HEADER_CPP + POINTS_CPP + "return wh_to_camera(cam, p);")
def to_camera(cam: CameraGPU, p: wp.vec3) -> wp.vec3:
    """World point ``p`` in ``cam``'s camera space (``POINTS_CPP``)."""
    ...


@wp.func_native(LAMBDA_HEADER_CPP + POINTS_CPP + "return wh_project(cam, c);")
def project(cam: CameraGPU, c: wp.vec3) -> wp.vec3:
    """Camera-space point -> (screen x, screen y, view depth) (``POINTS_CPP``)."""
    ...


@wp.func_native(
    LAMBDA_HEADER_CPP
    + POINTS_CPP
    + """
const wp::vec3* points_in = points.data;
wp::vec3* camera = pts.camera.data;
int* outcodes = pts.outcodes.data;
wp::vec3* screen = pts.screen.data;
const float near = cam.near, far = cam.far, tan_x = cam.tan_x, tan_y = cam.tan_y;
// (every point's screen slot written back: its old value where it lies behind the near plane;
// the arrays are the points' and three of this pass's own, which the compiler cannot tell apart)
#pragma clang loop vectorize(assume_safety)
for (int i = first; i < stop; ++i) {
    const wp::vec3 c = wh_to_camera(cam, points_in[i]);
    camera[i] = c;
    outcodes[i] = wh_outcode(c, near, far, tan_x, tan_y);
    const wp::vec3 s = wh_project(cam, c);
    screen[i] = wh_select(c[2] >= near, s, screen[i]);
}
"""
)
def project_points(points: wp.array(dtype=wp.vec3), cam: CameraGPU, pts: ProjectedPoints, first: int, stop: int):
    """Points ``first <= i < stop`` (contiguous) into ``pts``: camera space, outcodes and,
    in front of the near plane, screen points (``POINTS_CPP``), in a loop across them."""
    ...


@wp.func(inline=True)
def _clip_plane(cam: CameraGPU, k: int) -> wp.vec4d:
    """Camera-space clip plane k as (a, b, c, d): inside where a x + b y + c z + d >= 0.
    0 = near plane, 1..4 = guard band (x = +-gx z, y = +-gy z)."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    if k == 0:
        return wp.vec4d(zero, zero, one, -wp.float64(cam.near))
    gx = wp.float64(GUARD_PX / (0.5 * float(cam.width))) * wp.float64(cam.tan_x)
    gy = wp.float64(GUARD_PX / (0.5 * float(cam.height))) * wp.float64(cam.tan_y)
    if k == 1:
        return wp.vec4d(-one, zero, gx, zero)
    if k == 2:
        return wp.vec4d(one, zero, gx, zero)
    if k == 3:
        return wp.vec4d(zero, -one, gy, zero)
    return wp.vec4d(zero, one, gy, zero)


@wp.func(inline=True)
def _to_camera_f64(cam: CameraGPU, p: wp.vec3) -> wp.vec3d:
    """``to_camera`` in float64: the float32 inputs' differences and products are
    exact, so a corner 1e4 away keeps ~1e-12 rather than ~1e-3 of absolute error."""
    d = wp.vec3d(wp.float64(p[0]), wp.float64(p[1]), wp.float64(p[2])) - wp.vec3d(
        wp.float64(cam.origin[0]), wp.float64(cam.origin[1]), wp.float64(cam.origin[2])
    )
    r = wp.vec3d(wp.float64(cam.right[0]), wp.float64(cam.right[1]), wp.float64(cam.right[2]))
    u = wp.vec3d(wp.float64(cam.up[0]), wp.float64(cam.up[1]), wp.float64(cam.up[2]))
    f = wp.vec3d(wp.float64(cam.forward[0]), wp.float64(cam.forward[1]), wp.float64(cam.forward[2]))
    return wp.vec3d(wp.dot(d, r), wp.dot(d, u), wp.dot(d, f))


@wp.func(inline=True)
def _project_f64(cam: CameraGPU, c: wp.vec3d) -> wp.vec3:
    """``project`` of a float64 camera-space point (rounded to float32 at the end)."""
    hw = wp.float64(0.5 * float(cam.width))
    hh = wp.float64(0.5 * float(cam.height))
    inv_z = wp.float64(1.0) / c[2]
    sx = hw + c[0] * inv_z * (hw / wp.float64(cam.tan_x))
    sy = hh - c[1] * inv_z * (hh / wp.float64(cam.tan_y))
    return wp.vec3(float(sx), float(sy), float(c[2]))


@wp.func(inline=True)
def in_guard_band(cam: CameraGPU, s: wp.vec3) -> bool:
    return wp.abs(s[0] - 0.5 * float(cam.width)) <= GUARD_PX and wp.abs(s[1] - 0.5 * float(cam.height)) <= GUARD_PX


@wp.func(inline=True)
def _fan_vertex(
    tri: int,
    scene: SceneGPU,
    cam: CameraGPU,
    pts: ProjectedPoints,
    x: wp.float64,
    y: wp.float64,
    z: wp.float64,
    corner: int,
) -> wp.vec3:
    """Screen point of a clipped polygon's vertex: a corner that has one (in front of
    the near plane) takes the shared point unclipped neighbours use, so edges between
    the two paths match bit for bit; a cut point is projected from float64."""
    if corner >= 0:
        p = scene.indices[3 * tri + corner]
        if pts.camera[p][2] >= cam.near:
            return pts.screen[p]
    return _project_f64(cam, wp.vec3d(x, y, z))


@wp.func(inline=False)
def raster_clipped(
    tri: int,
    scene: SceneGPU,
    cam: CameraGPU,
    pts: ProjectedPoints,
    target: RasterTarget,
):
    """The rare path: a triangle crossing the near plane or leaving the guard band,
    clipped to a polygon and rasterized as a fan.

    Clipping runs in float64 on camera-space corners recomputed from the world-space
    points: in float32 a corner 1e4 away carries ~1e-3 of error, so the cut of such an
    edge with a near plane at 1e-5 can land at z <= 0 and the triangle vanish (a huge
    floor seen from 1e-3 above it)."""
    # Sutherland-Hodgman against the near plane and the guard band.  Each crossing
    # point is interpolated from the inside corner towards the outside one, so an edge
    # shared by two triangles is cut at bit-identical points (no crack).
    xs = _vec9d()
    ys = _vec9d()
    zs = _vec9d()
    src = _vec9i()
    for v in range(3):
        c = _to_camera_f64(cam, scene.points[scene.indices[3 * tri + v]])
        xs[v] = c[0]
        ys[v] = c[1]
        zs[v] = c[2]
        src[v] = v
    n = int(3)
    zero = wp.float64(0.0)
    for k in range(5):
        pl = _clip_plane(cam, k)
        ox = _vec9d()
        oy = _vec9d()
        oz = _vec9d()
        osrc = _vec9i()
        m = int(0)
        for i in range(n):
            j = (i + 1) % n
            pi = wp.vec3d(xs[i], ys[i], zs[i])
            pj = wp.vec3d(xs[j], ys[j], zs[j])
            di = pl[0] * pi[0] + pl[1] * pi[1] + pl[2] * pi[2] + pl[3]
            dj = pl[0] * pj[0] + pl[1] * pj[1] + pl[2] * pj[2] + pl[3]
            if di >= zero:
                ox[m] = pi[0]
                oy[m] = pi[1]
                oz[m] = pi[2]
                osrc[m] = src[i]
                m += 1
            if (di >= zero) != (dj >= zero):
                p_in = pi
                p_out = pj
                d_in = di
                d_out = dj
                if di < zero:
                    p_in = pj
                    p_out = pi
                    d_in = dj
                    d_out = di
                q = p_in + (p_out - p_in) * (d_in / (d_in - d_out))
                ox[m] = q[0]
                oy[m] = q[1]
                oz[m] = q[2]
                if k == 0:
                    oz[m] = -pl[3]  # exactly on the near plane
                osrc[m] = -1
                m += 1
        xs = ox
        ys = oy
        zs = oz
        src = osrc
        n = m
        if n < 3:
            return
    s0 = _fan_vertex(tri, scene, cam, pts, xs[0], ys[0], zs[0], src[0])
    for i in range(1, n - 1):
        s1 = _fan_vertex(tri, scene, cam, pts, xs[i], ys[i], zs[i], src[i])
        s2 = _fan_vertex(tri, scene, cam, pts, xs[i + 1], ys[i + 1], zs[i + 1], src[i + 1])
        raster_triangle(s0, s1, s2, tri, scene, cam, target)
