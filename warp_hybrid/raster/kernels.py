"""Every Warp kernel of the primary-visibility stage (one compile unit).

Four passes fill a ``GBuffer``:

* ``camera_points_kernel`` (one thread per vertex): every point in camera space and,
  in front of the near plane, projected to the screen, so the triangles sharing a
  vertex reuse it (and see bit-identical corners).
* ``visibility_kernel`` (one thread per triangle): trivial frustum rejects, clip
  against the near plane (and a far-off guard band so fixed-point coordinates never
  overflow; in float64 from the world-space corners, see ``_raster_clipped``),
  project, snap to a 1/256-pixel fixed-point grid and walk, row by row,
  the pixel centres of the triangle's span (bounding box, narrowed per row when it is
  NARROW_PX pixels or wider) with
  exact integer edge functions and a top-left fill rule, so shared edges leave no
  crack and no pixel is covered twice.  Each covered pixel gets one ``atomic_min`` of
  a 64-bit key (for the overdraw diagnostic, one count instead): the float32 bits
  of the view depth (positive floats order like their bit patterns) in the high 32
  bits, the triangle id in the low 32, so equal depths resolve to the smaller id.
  Alpha cut-outs are tested per fragment and skipped below their threshold.
* ``resolve_kernel`` (one thread per pixel): takes the smallest key over the
  visibility slices, intersects the pixel's camera ray with the winning triangle
  (exact depth and barycentrics) and evaluates the surface, textures filtered over
  the pixel's footprint (``pixel_footprint``: ray differentials of the camera ray on
  the triangle's plane, which picks the mip level).
* ``raycast_kernel`` (one thread per pixel): the reference path, ``wp.mesh_query_ray``
  through each pixel centre from the near plane to the far plane, stepping past
  cut-away hits; same surface evaluation and footprint, so both paths agree.

Both per-pixel passes write through ``GBufferRows`` (flat views of the G-buffer);
``GBufferArrays`` is the 2-D struct the later stages' kernels read.

No back-face culling: the G-buffer must match the ray cast, which sees both sides.
Screen space: x right, y down, pixel (i, j) has its centre at (i + 0.5, j + 0.5).
"""

from __future__ import annotations

import warp as wp

from ..scene.device import FLAG_CUTOUT, CameraGPU, SceneGPU
from ..scene.surface import is_cut_away, surface_at_grad, uv_footprint

wp.set_module_options({"enable_backward": False})

# Visibility buffer: an empty pixel holds the largest key.
EMPTY_KEY = wp.constant(wp.uint64(0xFFFFFFFFFFFFFFFF))
# What the visibility kernel writes: the depth key (atomic min) or a fragment count.
MODE_DEPTH = wp.constant(0)
MODE_COUNT = wp.constant(1)
# Fixed point: 8 sub-pixel bits.  Vertices are kept within +-GUARD_PX pixels of the
# screen centre (clipping against guard-band planes beyond that), so coordinates stay
# below 2^27 units and edge-function products fit an int64 exactly.
SUBPIXEL = wp.constant(wp.int64(256))
HALF_SUBPIXEL = wp.constant(wp.int64(128))
GUARD_PX = wp.constant(262144.0)
# Triangles whose pixel bounding box is narrower than this test every pixel in it
# rather than narrowing each row's span first.
NARROW_PX = wp.constant(4)
# Ray-cast path: at most this many cut-away hits are stepped past per pixel.
MAX_CUTOUT_LAYERS = wp.constant(32)

# A clipped polygon has at most 3 + 5 vertices (near plane + 4 guard-band planes):
# float64 coordinates, and which corner (0..2) each vertex is, -1 for a cut point.
_vec9d = wp.types.vector(length=9, dtype=wp.float64)
_vec9i = wp.types.vector(length=9, dtype=wp.int32)


@wp.struct
class GBufferArrays:
    """The ``GBuffer`` arrays as one kernel argument, indexed [row, column] (what the
    stages after the primary pass take; see ``gbuffer_arrays``)."""

    position: wp.array2d(dtype=wp.vec3)
    normal: wp.array2d(dtype=wp.vec3)
    geometric_normal: wp.array2d(dtype=wp.vec3)
    depth: wp.array2d(dtype=wp.float32)
    albedo: wp.array2d(dtype=wp.vec3)
    specular: wp.array2d(dtype=wp.vec3)
    emission: wp.array2d(dtype=wp.vec3)
    optics: wp.array2d(dtype=wp.vec4)
    material_id: wp.array2d(dtype=wp.int32)
    triangle_id: wp.array2d(dtype=wp.int32)
    barycentric: wp.array2d(dtype=wp.vec2)


@wp.func_native("""union { float f; unsigned int u; } c; c.f = x; return (uint64_t)c.u;""")
def _float_bits(x: float) -> wp.uint64: ...


@wp.func(inline=True)
def camera_ray_dir(cam: CameraGPU, px: float, py: float) -> wp.vec3:
    """Direction of the camera ray through image point (px, py) in pixels (row 0 at
    the top).  Not normalised: its component along ``forward`` is 1, so a ray
    parameter t along it *is* the view depth."""
    ndc_x = 2.0 * px / float(cam.width) - 1.0
    ndc_y = 1.0 - 2.0 * py / float(cam.height)
    return cam.forward + cam.right * (ndc_x * cam.tan_x) + cam.up * (ndc_y * cam.tan_y)


@wp.func(inline=True)
def pixel_footprint(scene: SceneGPU, cam: CameraGPU, tri: int, d: wp.vec3) -> wp.vec4:
    """uv footprint (du/dx, dv/dx, du/dy, dv/dy) on triangle ``tri`` of the pixel whose
    camera ray is ``d``: the ray differentials of one pixel step right and down."""
    ddx = cam.right * (2.0 * cam.tan_x / float(cam.width))
    ddy = cam.up * (-2.0 * cam.tan_y / float(cam.height))
    return uv_footprint(scene, tri, cam.origin, d, ddx, ddy)


@wp.func(inline=True)
def _to_camera(cam: CameraGPU, p: wp.vec3) -> wp.vec3:
    d = p - cam.origin
    return wp.vec3(wp.dot(d, cam.right), wp.dot(d, cam.up), wp.dot(d, cam.forward))


@wp.func(inline=True)
def _project(cam: CameraGPU, c: wp.vec3) -> wp.vec3:
    """Camera-space point -> (screen x, screen y, view depth)."""
    hw = 0.5 * float(cam.width)
    hh = 0.5 * float(cam.height)
    inv_z = 1.0 / c[2]
    return wp.vec3(hw + c[0] * inv_z * (hw / cam.tan_x), hh - c[1] * inv_z * (hh / cam.tan_y), c[2])


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
def _triangle_points(scene: SceneGPU, tri: int) -> wp.mat33:
    """The triangle's corners as the rows of a matrix."""
    k = 3 * tri
    p0 = scene.points[scene.indices[k]]
    p1 = scene.points[scene.indices[k + 1]]
    p2 = scene.points[scene.indices[k + 2]]
    return wp.mat33(p0[0], p0[1], p0[2], p1[0], p1[1], p1[2], p2[0], p2[1], p2[2])


@wp.func(inline=True)
def _fixed(v: float) -> wp.int64:
    return wp.int64(wp.floor(v * 256.0 + 0.5))


@wp.func(inline=True)
def _fill_bias(dx: wp.int64, dy: wp.int64) -> wp.int64:
    """Top-left rule for the edge (dx, dy) of a positively oriented triangle (y down):
    top edges (dy == 0, dx > 0) and left edges (dy < 0) own the pixel centres exactly
    on them (bias 0); other edges do not (bias -1 turns 'w >= 0' into 'w > 0')."""
    if dy < wp.int64(0) or (dy == wp.int64(0) and dx > wp.int64(0)):
        return wp.int64(0)
    return wp.int64(-1)


@wp.func(inline=False)
def _fragment_kept(scene: SceneGPU, cam: CameraGPU, tri: int, x: int, y: int) -> bool:
    """Alpha test of a cut-out triangle at pixel (x, y), at the exact ray hit."""
    pts = _triangle_points(scene, tri)
    d = camera_ray_dir(cam, float(x) + 0.5, float(y) + 0.5)
    h = ray_triangle(cam.origin, d, pts[0], pts[1], pts[2])
    return not is_cut_away(scene, tri, h[1], h[2])


@wp.func(inline=True)
def _inv_step(step: wp.int64) -> float:
    if step == wp.int64(0):
        return 0.0
    return 1.0 / float(step)


@wp.func(inline=True)
def _span(w: wp.int64, step: wp.int64, inv_step: float, span_max: float, span: wp.vec2) -> wp.vec2:
    """Narrow the pixel-offset interval ``span`` to where w + k * step >= 0 (with one
    pixel of slack for rounding); an empty row gives lo > hi."""
    if step == wp.int64(0):
        if w < wp.int64(0):
            return wp.vec2(1.0, 0.0)
        return span
    r = wp.clamp(-float(w) * inv_step, -2.0, span_max)
    if step > wp.int64(0):
        return wp.vec2(wp.max(span[0], wp.floor(r) - 1.0), span[1])
    return wp.vec2(span[0], wp.min(span[1], wp.ceil(r) + 1.0))


@wp.func(inline=True)
def _raster_triangle(
    a: wp.vec3,
    b: wp.vec3,
    c: wp.vec3,
    tri: int,
    scene: SceneGPU,
    cam: CameraGPU,
    vis: wp.array3d(dtype=wp.uint64),
    mode: int,
    slot: int,
):
    """Rasterize one projected triangle (screen x, screen y, view depth per corner)
    into ``vis[slot]``."""
    ax = _fixed(a[0])
    ay = _fixed(a[1])
    bx = _fixed(b[0])
    by = _fixed(b[1])
    cx = _fixed(c[0])
    cy = _fixed(c[1])
    za = a[2]
    zb = b[2]
    zc = c[2]
    area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    if area == wp.int64(0):
        return
    if area < wp.int64(0):
        tx = bx
        bx = cx
        cx = tx
        ty = by
        by = cy
        cy = ty
        tz = zb
        zb = zc
        zc = tz
        area = -area

    # Pixel centres p*256 + 128 inside the bounding box (arithmetic shifts floor).
    x0 = int((wp.min(wp.min(ax, bx), cx) + HALF_SUBPIXEL - wp.int64(1)) >> wp.int64(8))
    x1 = int((wp.max(wp.max(ax, bx), cx) - HALF_SUBPIXEL) >> wp.int64(8))
    y0 = int((wp.min(wp.min(ay, by), cy) + HALF_SUBPIXEL - wp.int64(1)) >> wp.int64(8))
    y1 = int((wp.max(wp.max(ay, by), cy) - HALF_SUBPIXEL) >> wp.int64(8))
    x0 = wp.max(x0, 0)
    y0 = wp.max(y0, 0)
    x1 = wp.min(x1, cam.width - 1)
    y1 = wp.min(y1, cam.height - 1)
    if x0 > x1 or y0 > y1:
        return
    cutout = (scene.materials[scene.triangle_material[tri]].flags & FLAG_CUTOUT) != 0

    # w_a = E(b, c, p), w_b = E(c, a, p), w_c = E(a, b, p) with
    # E(u, v, p) = (v.x - u.x)(p.y - u.y) - (v.y - u.y)(p.x - u.x); w_a + w_b + w_c = area.
    bias_a = _fill_bias(cx - bx, cy - by)
    bias_b = _fill_bias(ax - cx, ay - cy)
    bias_c = _fill_bias(bx - ax, by - ay)
    step_a = (by - cy) * SUBPIXEL
    step_b = (cy - ay) * SUBPIXEL
    step_c = (ay - by) * SUBPIXEL
    inv_za = 1.0 / za
    inv_zb = 1.0 / zb
    inv_zc = 1.0 / zc
    farea = float(area)
    # z = farea / denom lies in (0, far] exactly when denom >= farea / far.
    min_denom = farea / cam.far
    # Rows wider than NARROW_PX pixels narrow their span first: reciprocal steps give
    # the covered span up to rounding; it is widened by one pixel each side and every
    # pixel in it still takes the exact integer test.  Narrow boxes test every pixel.
    wide = x1 - x0 >= NARROW_PX
    span_max = float(x1 - x0 + 2)
    inv_sa = float(0.0)
    inv_sb = float(0.0)
    inv_sc = float(0.0)
    if wide:
        inv_sa = _inv_step(step_a)
        inv_sb = _inv_step(step_b)
        inv_sc = _inv_step(step_c)
    px0 = wp.int64(x0) * SUBPIXEL + HALF_SUBPIXEL
    for y in range(y0, y1 + 1):
        py = wp.int64(y) * SUBPIXEL + HALF_SUBPIXEL
        wa = (cx - bx) * (py - by) - (cy - by) * (px0 - bx) + bias_a
        wb = (ax - cx) * (py - cy) - (ay - cy) * (px0 - cx) + bias_b
        wc = (bx - ax) * (py - ay) - (by - ay) * (px0 - ax) + bias_c
        lo = int(0)
        hi = x1 - x0
        if wide:
            span = _span(wa, step_a, inv_sa, span_max, wp.vec2(0.0, span_max))
            span = _span(wb, step_b, inv_sb, span_max, span)
            span = _span(wc, step_c, inv_sc, span_max, span)
            lo = wp.max(int(span[0]), 0)
            hi = wp.min(int(span[1]), x1 - x0)
            wa += wp.int64(lo) * step_a
            wb += wp.int64(lo) * step_b
            wc += wp.int64(lo) * step_c
        for k in range(lo, hi + 1):
            if (wa | wb | wc) >= wp.int64(0):
                x = x0 + k
                # Perspective-correct depth: 1/z is linear in screen space.  (The fill
                # biases shift w by one 2^-16 pixel-area unit: irrelevant for depth.)
                denom = float(wa) * inv_za + float(wb) * inv_zb + float(wc) * inv_zc
                if denom >= min_denom:
                    z = farea / denom
                    keep = True
                    if cutout:
                        keep = _fragment_kept(scene, cam, tri, x, y)
                    if keep:
                        if mode == MODE_DEPTH:
                            wp.atomic_min(vis, slot, y, x, (_float_bits(z) << wp.uint64(32)) | wp.uint64(tri))
                        else:
                            wp.atomic_add(vis, slot, y, x, wp.uint64(1))
            wa += step_a
            wb += step_b
            wc += step_c


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
    """``_to_camera`` in float64: the float32 inputs' differences and products are
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
    """``_project`` of a float64 camera-space point (rounded to float32 at the end)."""
    hw = wp.float64(0.5 * float(cam.width))
    hh = wp.float64(0.5 * float(cam.height))
    inv_z = wp.float64(1.0) / c[2]
    sx = hw + c[0] * inv_z * (hw / wp.float64(cam.tan_x))
    sy = hh - c[1] * inv_z * (hh / wp.float64(cam.tan_y))
    return wp.vec3(float(sx), float(sy), float(c[2]))


@wp.func(inline=True)
def _in_guard_band(cam: CameraGPU, s: wp.vec3) -> bool:
    return wp.abs(s[0] - 0.5 * float(cam.width)) <= GUARD_PX and wp.abs(s[1] - 0.5 * float(cam.height)) <= GUARD_PX


@wp.func(inline=True)
def _fan_vertex(
    tri: int,
    scene: SceneGPU,
    cam: CameraGPU,
    screen_points: wp.array(dtype=wp.vec3),
    camera_points: wp.array(dtype=wp.vec3),
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
        if camera_points[p][2] >= cam.near:
            return screen_points[p]
    return _project_f64(cam, wp.vec3d(x, y, z))


@wp.func(inline=False)
def _raster_clipped(
    tri: int,
    scene: SceneGPU,
    cam: CameraGPU,
    screen_points: wp.array(dtype=wp.vec3),
    camera_points: wp.array(dtype=wp.vec3),
    vis: wp.array3d(dtype=wp.uint64),
    mode: int,
    slot: int,
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
    s0 = _fan_vertex(tri, scene, cam, screen_points, camera_points, xs[0], ys[0], zs[0], src[0])
    for i in range(1, n - 1):
        s1 = _fan_vertex(tri, scene, cam, screen_points, camera_points, xs[i], ys[i], zs[i], src[i])
        s2 = _fan_vertex(tri, scene, cam, screen_points, camera_points, xs[i + 1], ys[i + 1], zs[i + 1], src[i + 1])
        _raster_triangle(s0, s1, s2, tri, scene, cam, vis, mode, slot)


@wp.kernel
def camera_points_kernel(
    scene: SceneGPU,
    cam: CameraGPU,
    camera_points: wp.array(dtype=wp.vec3),
    screen_points: wp.array(dtype=wp.vec3),
    start: int,
    step: int,
):
    """Points start, start + step, ... in camera space (x right, y up, z = view depth)
    and, in front of the near plane, on screen (x, y in pixels, view depth): once per
    vertex rather than once per triangle corner."""
    i = start + wp.tid() * step
    c = _to_camera(cam, scene.points[i])
    camera_points[i] = c
    if c[2] >= cam.near:
        screen_points[i] = _project(cam, c)


@wp.kernel
def visibility_kernel(
    scene: SceneGPU,
    cam: CameraGPU,
    camera_points: wp.array(dtype=wp.vec3),
    screen_points: wp.array(dtype=wp.vec3),
    vis: wp.array3d(dtype=wp.uint64),
    mode: int,
    slot: int,
    tri_start: int,
    tri_step: int,
):
    """Rasterize triangles tri_start, tri_start + tri_step, ... (corners from
    ``camera_points_kernel``) into ``vis[slot]``: depth keys (MODE_DEPTH) or fragment
    counts (MODE_COUNT)."""
    tri = tri_start + wp.tid() * tri_step
    i0 = scene.indices[3 * tri]
    i1 = scene.indices[3 * tri + 1]
    i2 = scene.indices[3 * tri + 2]
    c0 = camera_points[i0]
    c1 = camera_points[i1]
    c2 = camera_points[i2]

    # Trivial rejects: wholly behind the near plane, beyond the far plane, or outside
    # one side plane of the view frustum.
    if c0[2] < cam.near and c1[2] < cam.near and c2[2] < cam.near:
        return
    if c0[2] > cam.far and c1[2] > cam.far and c2[2] > cam.far:
        return
    if c0[0] > cam.tan_x * c0[2] and c1[0] > cam.tan_x * c1[2] and c2[0] > cam.tan_x * c2[2]:
        return
    if -c0[0] > cam.tan_x * c0[2] and -c1[0] > cam.tan_x * c1[2] and -c2[0] > cam.tan_x * c2[2]:
        return
    if c0[1] > cam.tan_y * c0[2] and c1[1] > cam.tan_y * c1[2] and c2[1] > cam.tan_y * c2[2]:
        return
    if -c0[1] > cam.tan_y * c0[2] and -c1[1] > cam.tan_y * c1[2] and -c2[1] > cam.tan_y * c2[2]:
        return

    if c0[2] >= cam.near and c1[2] >= cam.near and c2[2] >= cam.near:
        s0 = screen_points[i0]
        s1 = screen_points[i1]
        s2 = screen_points[i2]
        if _in_guard_band(cam, s0) and _in_guard_band(cam, s1) and _in_guard_band(cam, s2):
            _raster_triangle(s0, s1, s2, tri, scene, cam, vis, mode, slot)
            return

    _raster_clipped(tri, scene, cam, screen_points, camera_points, vis, mode, slot)


@wp.struct
class GBufferRows:
    """The ``GBuffer`` arrays as flat (height * width) views, row-major: the primary
    passes store pixel (x, y) at ``y * width + x`` (one index instead of two checked
    ones per store, which showed up across ten stores per pixel)."""

    position: wp.array(dtype=wp.vec3)
    normal: wp.array(dtype=wp.vec3)
    geometric_normal: wp.array(dtype=wp.vec3)
    depth: wp.array(dtype=wp.float32)
    albedo: wp.array(dtype=wp.vec3)
    specular: wp.array(dtype=wp.vec3)
    emission: wp.array(dtype=wp.vec3)
    optics: wp.array(dtype=wp.vec4)
    material_id: wp.array(dtype=wp.int32)
    triangle_id: wp.array(dtype=wp.int32)
    barycentric: wp.array(dtype=wp.vec2)


@wp.func(inline=True)
def _write_visibility(gb: GBufferRows, i: int, tri: int, t: float, bu: float, bv: float):
    """The visibility record of a pixel: which triangle, how deep, where on it."""
    gb.triangle_id[i] = tri
    gb.depth[i] = t
    gb.barycentric[i] = wp.vec2(bu, bv)


@wp.func(inline=True)
def _write_background(gb: GBufferRows, i: int):
    zero = wp.vec3(0.0, 0.0, 0.0)
    gb.position[i] = zero
    gb.normal[i] = zero
    gb.geometric_normal[i] = zero
    gb.depth[i] = wp.inf
    gb.albedo[i] = zero
    gb.specular[i] = zero
    gb.emission[i] = zero
    gb.optics[i] = wp.vec4(0.0, 0.0, 0.0, 0.0)
    gb.material_id[i] = -1
    gb.triangle_id[i] = -1
    gb.barycentric[i] = wp.vec2(0.0, 0.0)


@wp.func(inline=True)
def _textured(scene: SceneGPU, tri: int) -> bool:
    """Whether the triangle's material samples any texture."""
    m = scene.materials[scene.triangle_material[tri]]
    slots = wp.max(wp.max(m.diffuse_tex, m.emissive_tex), wp.max(m.roughness_tex, m.metallic_tex))
    return wp.max(slots, m.opacity_tex) >= 0


@wp.func(inline=True)
def _write_hit(
    gb: GBufferRows,
    i: int,
    scene: SceneGPU,
    cam: CameraGPU,
    tri: int,
    bu: float,
    bv: float,
    d: wp.vec3,
):
    """Evaluate the surface (textures filtered over the pixel's footprint) and store
    its attributes at flat index ``i`` (``d`` is the camera ray, unit forward component)."""
    footprint = wp.vec4(0.0, 0.0, 0.0, 0.0)
    if _textured(scene, tri):
        footprint = pixel_footprint(scene, cam, tri, d)
    h = surface_at_grad(scene, tri, bu, bv, d, footprint)
    gb.position[i] = h.position
    gb.normal[i] = h.normal
    gb.geometric_normal[i] = h.geometric_normal
    gb.albedo[i] = h.albedo
    gb.specular[i] = h.specular
    gb.emission[i] = h.emission
    reflectivity = 0.2126 * h.specular[0] + 0.7152 * h.specular[1] + 0.0722 * h.specular[2]
    gb.optics[i] = wp.vec4(reflectivity, h.ior, h.opacity, h.roughness)
    gb.material_id[i] = h.material


@wp.func(inline=True)
def _write_exact_hit(gb: GBufferRows, i: int, scene: SceneGPU, cam: CameraGPU, tri: int, d: wp.vec3):
    """The visibility record of camera ray ``d`` (unit forward component) on triangle
    ``tri``, intersected exactly from the camera origin (both primary paths use it, so
    their depths and barycentrics come from the same arithmetic)."""
    pts = _triangle_points(scene, tri)
    h = ray_triangle(cam.origin, d, pts[0], pts[1], pts[2])
    t = h[0]
    if h[3] == 0.0 or not (t > 0.0):
        # Grazing: the ray runs (numerically) in the triangle's plane.
        p = pts[0] * h[1] + pts[1] * h[2] + pts[2] * (1.0 - h[1] - h[2])
        t = wp.dot(p - cam.origin, cam.forward)
    _write_visibility(gb, i, tri, t, h[1], h[2])


@wp.kernel
def resolve_kernel(
    scene: SceneGPU,
    cam: CameraGPU,
    vis: wp.array3d(dtype=wp.uint64),
    gb: GBufferRows,
    row0: int,
    row_step: int,
):
    """Per pixel: the nearest key over all visibility slices -> exact hit -> the
    visibility record (triangle, depth, barycentrics); ``surface_kernel`` does the rest."""
    r, x = wp.tid()
    y = row0 + r * row_step
    i = y * cam.width + x
    key = vis[0, y, x]
    for s in range(1, vis.shape[0]):
        key = wp.min(key, vis[s, y, x])
    if key == EMPTY_KEY:
        _write_background(gb, i)
        return
    tri = int(key & wp.uint64(0xFFFFFFFF))
    d = camera_ray_dir(cam, float(x) + 0.5, float(y) + 0.5)
    _write_exact_hit(gb, i, scene, cam, tri, d)


@wp.kernel
def raycast_kernel(scene: SceneGPU, cam: CameraGPU, gb: GBufferRows, row0: int, row_step: int):
    """Per pixel: closest ``wp.mesh_query_ray`` hit between the near and far planes,
    stepping past hits in cut-out holes -> the visibility record."""
    r, x = wp.tid()
    y = row0 + r * row_step
    i = y * cam.width + x
    if scene.mesh == wp.uint64(0):
        _write_background(gb, i)
        return
    d = camera_ray_dir(cam, float(x) + 0.5, float(y) + 0.5)
    t_base = cam.near
    for layer in range(MAX_CUTOUT_LAYERS):
        q = wp.mesh_query_ray(scene.mesh, cam.origin + d * t_base, d, cam.far - t_base)
        if not q.result:
            break
        t = t_base + q.t
        if not is_cut_away(scene, q.face, q.u, q.v):
            # The BVH picks the face; depth and barycentrics are recomputed exactly from
            # the camera origin (mesh_query_ray works relative to far-away corners in
            # float32, off by up to tens of percent on 1e4-sized triangles seen up close).
            _write_exact_hit(gb, i, scene, cam, q.face, d)
            return
        t_base = t + 1.0e-5 * t
    _write_background(gb, i)


@wp.kernel
def surface_kernel(scene: SceneGPU, cam: CameraGPU, gb: GBufferRows, row0: int, row_step: int):
    """Per pixel: evaluate the surface named by the visibility record (whichever
    primary path wrote it) into the remaining G-buffer attributes."""
    r, x = wp.tid()
    y = row0 + r * row_step
    i = y * cam.width + x
    tri = gb.triangle_id[i]
    if tri < 0:
        _write_background(gb, i)
        return
    d = camera_ray_dir(cam, float(x) + 0.5, float(y) + 0.5)
    b = gb.barycentric[i]
    _write_hit(gb, i, scene, cam, tri, b[0], b[1], d)


def gbuffer_rows(gbuffer) -> GBufferRows:
    """Flat views of a ``GBuffer``'s arrays as the kernel-side struct of the primary
    passes."""
    s = GBufferRows()
    for name, array in gbuffer.arrays().items():
        setattr(s, name, array.reshape((-1,)))
    return s


def gbuffer_arrays(gbuffer) -> GBufferArrays:
    """Pack a ``GBuffer``'s arrays into the kernel-side struct."""
    s = GBufferArrays()
    for name, array in gbuffer.arrays().items():
        setattr(s, name, array)
    return s
