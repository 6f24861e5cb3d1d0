"""Coverage of one projected triangle: fixed-point edge functions with a top-left fill
rule, one atomic min of a depth key per covered pixel centre (``@wp.func``).

Corners are snapped to a 1/256-pixel fixed-point grid; the pixel centres of the
triangle's span (bounding box, narrowed per row when it is ``NARROW_PX`` pixels or
wider) take exact integer edge tests, so shared edges leave no crack and no pixel is
covered twice.  Each covered pixel gets one ``atomic_min`` of a 64-bit *depth key*
(for the overdraw diagnostic, one count instead): the float32 bits of the view depth
(positive floats order like their bit patterns) in the high 32 bits, the triangle id
in the low 32, so equal depths resolve to the smaller id.  Alpha cut-outs are tested
per fragment and skipped below their threshold.  Screen space: x right, y down, pixel
(i, j) has its centre at (i + 0.5, j + 0.5).

The point tested in each pixel is the camera's sample point (``CameraGPU.sample``, the
centre unless the frame is supersampled): the snapped corners are shifted by
``0.5 - sample``, which the camera keeps on the fixed-point grid, so the shift is a
whole number of units, exact, and the same for every triangle sharing a corner (still
watertight); the centres tested against the shifted corners are the sample points
against the true ones.  At the centre the shift is 0 and nothing changes.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import SAMPLE_GRID, CameraGPU, pixel_ray
from ..core.scene_gpu import FLAG_CUTOUT, SceneGPU
from ..scene.device.surface import is_cut_away
from .hit_record import ray_triangle, triangle_points

# Key buffer: an empty pixel holds the largest key.
EMPTY_KEY = wp.constant(wp.uint64(0xFFFFFFFFFFFFFFFF))
# What the coverage pass writes: the depth key (atomic min) or a fragment count.
MODE_DEPTH = wp.constant(0)
MODE_COUNT = wp.constant(1)
# Fixed point: 8 sub-pixel bits (coordinates stay below 2^27 units inside the guard
# band of ``clipping.py``, so edge-function products fit an int64 exactly), the grid
# sample offsets are snapped to.
SUBPIXEL = wp.constant(wp.int64(SAMPLE_GRID))
HALF_SUBPIXEL = wp.constant(wp.int64(128))
# Triangles whose pixel bounding box is narrower than this test every pixel in it
# rather than narrowing each row's span first.
NARROW_PX = wp.constant(4)


@wp.struct
class RasterTarget:
    """Where coverage goes: one thread's ``slot`` of the key buffer ``keys`` (threads,
    H, W), written as depth keys (``MODE_DEPTH``) or fragment counts (``MODE_COUNT``),
    in the rows ``row_begin`` up to ``row_end`` only (a thread's band of rows, or all)."""

    keys: wp.array3d(dtype=wp.uint64)
    slot: int
    mode: int
    row_begin: int
    row_end: int


@wp.func_native("""union { float f; unsigned int u; } c; c.f = x; return (uint64_t)c.u;""")
def _float_bits(x: float) -> wp.uint64: ...


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
    pts = triangle_points(scene, tri)
    d = pixel_ray(cam, x, y)
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
def raster_triangle(
    a: wp.vec3,
    b: wp.vec3,
    c: wp.vec3,
    tri: int,
    scene: SceneGPU,
    cam: CameraGPU,
    target: RasterTarget,
):
    """Rasterize one projected triangle (screen x, screen y, view depth per corner)
    into ``target`` (its rows only), sampled at the camera's sample point (see the
    module docstring)."""
    shift_x = _fixed(0.5 - cam.sample[0])
    shift_y = _fixed(0.5 - cam.sample[1])
    ax = _fixed(a[0]) + shift_x
    ay = _fixed(a[1]) + shift_y
    bx = _fixed(b[0]) + shift_x
    by = _fixed(b[1]) + shift_y
    cx = _fixed(c[0]) + shift_x
    cy = _fixed(c[1]) + shift_y
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
    y0 = wp.max(y0, target.row_begin)
    x1 = wp.min(x1, cam.width - 1)
    y1 = wp.min(y1, target.row_end - 1)
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
                        if target.mode == MODE_DEPTH:
                            wp.atomic_min(
                                target.keys, target.slot, y, x, (_float_bits(z) << wp.uint64(32)) | wp.uint64(tri)
                            )
                        else:
                            wp.atomic_add(target.keys, target.slot, y, x, wp.uint64(1))
            wa += step_a
            wb += step_b
            wc += step_c
