"""Coverage of a batch of triangles (a cluster) in native code: their setup across lanes.

``kernels._cover_triangle`` set up one triangle at a time: its corners' gathers, the
frustum's trivial rejects, the guard-band test, the fixed-point snap, the area and the
bounding box, scalar, about 54 ns a triangle on the glass dragon's 100k small ones (the
pass took 5.4 ms where almost no triangle covers a pixel).  ``cover_batch`` does that
setup for up to ``BATCH_TRIANGLES`` triangles at once, in loops across them that the
compiler vectorises (gathers, float and 64-bit integer lanes; the trivial rejects from
the corners' outcodes, ``clipping.POINTS_CPP``, which the points pass computes once a
point: on the glass dragon the pass's CPU time fell 14%), then rasterizes the ones
left with a pixel centre in their box one at a time: ``coverage.raster_triangle``'s
row and pixel loops, operation for operation (each float operation a Warp call, so
nothing is fused differently), into the same keys; a wide triangle's row span of depth
keys across lanes (each pixel's key read and written back, lowered where covered, as only
this thread writes these rows), a narrow one's box in tiles of ``NARROW_PX`` x
``NARROW_PX`` pixel centres across lanes, then their keys likewise (the glass dragon's
coverage pass 9-11% less CPU time: 70% of its triangles' boxes fit one tile).  A triangle that needs more (it
crosses the near plane or leaves the guard band, or its material is cut out) is
returned in a bit mask for the Warp path (``raster_clipped``, ``raster_triangle``).
Only on the CPU: on CUDA a launch item is one cluster's triangles one at a time as
before.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU
from ..core.constants import CLUSTER_TRIANGLES
from ..core.native_rows import LAMBDA_HEADER_CPP, float_literal
from ..core.scene_gpu import FLAG_CUTOUT, SceneGPU
from .clipping import GUARD_PX, IN_FRONT_BIT, OUTSIDE_BITS, ProjectedPoints
from .coverage import HALF_SUBPIXEL, MODE_DEPTH, NARROW_PX, SUBPIXEL, RasterTarget

#: The most triangles one call sets up (a cluster's; one bit each in the mask it returns).
BATCH_TRIANGLES = CLUSTER_TRIANGLES


_COVER_BATCH_CPP = f"""
#if defined(__CUDA_ARCH__)
// (on CUDA every triangle goes the Warp path, whose key updates are atomic)
return stop - first >= {BATCH_TRIANGLES} ? ~(uint64_t)0 : ((uint64_t)1 << (stop - first)) - 1;
#else
{LAMBDA_HEADER_CPP}
constexpr int B = {BATCH_TRIANGLES};
constexpr int64_t SUB = {int(SUBPIXEL)};
constexpr int64_t HALF_SUB = {int(HALF_SUBPIXEL)};
constexpr int TILE = {int(NARROW_PX)};  // (a narrow box's columns fit one tile's)
const int n = stop - first;
const int* indices = scene.indices.data;
const int* outcodes = pts.outcodes.data;
const wp::vec3* screen = pts.screen.data;
const float far = cam.far;
const float half_w = wp::mul(0.5f, (float)cam.width), half_h = wp::mul(0.5f, (float)cam.height);
const float guard = {float_literal(GUARD_PX)};
auto fixed = [&](const float v) -> int64_t {{ return (int64_t)wp::floor(wp::add(wp::mul(v, 256.0f), 0.5f)); }};
const int64_t shift_x = fixed(wp::sub(0.5f, cam.sample[0]));
const int64_t shift_y = fixed(wp::sub(0.5f, cam.sample[1]));
int64_t ax[B], ay[B], bx[B], by[B], cx[B], cy[B], area[B];
float za[B], zb[B], zc[B];
int bx0[B], bx1[B], by0[B], by1[B];
bool live[B], slow[B];
// the corners, triangle by triangle (sixteen at a time; past the batch's end its last again):
// the bits their outcodes share (``clipping.POINTS_CPP``), and each screen point one 16-byte
// load (its fourth float the next point's, or past the last the points' spare one), whose
// components the sixteen lanes' registers give up at once (``wh_unpack16``: gathering
// them across lanes took a cycle or more a lane, nine gathers)
static_assert(B % 16 == 0, "whole groups of 16 lanes");
int commons[B];
float s0x[B], s0y[B], s0z[B], s1x[B], s1y[B], s1z[B], s2x[B], s2y[B], s2z[B];
for (int g = 0; g < n; g += 16) {{
    wh_float4 v0[16], v1[16], v2[16];
    #pragma clang loop vectorize(disable)
    for (int q = 0; q < 16; ++q) {{
        const int t = first + wp::min(g + q, n - 1);
        const int i0 = indices[3 * t], i1 = indices[3 * t + 1], i2 = indices[3 * t + 2];
        commons[g + q] = outcodes[i0] & outcodes[i1] & outcodes[i2];
        v0[q] = wh_load4((const float*)(screen + i0));
        v1[q] = wh_load4((const float*)(screen + i1));
        v2[q] = wh_load4((const float*)(screen + i2));
    }}
    wh_unpack16(v0, s0x + g, s0y + g, s0z + g, nullptr);
    wh_unpack16(v1, s1x + g, s1y + g, s1z + g, nullptr);
    wh_unpack16(v2, s2x + g, s2y + g, s2z + g, nullptr);
}}
// the setup across the batch: the rejects, the guard band, the snap, the orientation, the box
#pragma clang loop vectorize(enable)
for (int j = 0; j < n; ++j) {{
    // (the corners' outcodes: the trivial rejects where they share a bit beyond a plane,
    // wholly in front of the near plane where they share that bit)
    const int common = commons[j];
    const bool reject = (common & {int(OUTSIDE_BITS)}) != 0;
    const bool front = (common & {int(IN_FRONT_BIT)}) != 0;
    // (screen points exist only in front of the near plane: read every lane, used only there)
    const wp::vec3 s0(s0x[j], s0y[j], s0z[j]), s1(s1x[j], s1y[j], s1z[j]), s2(s2x[j], s2y[j], s2z[j]);
    auto inside = [&](const wp::vec3& s) {{
        return wp::abs(wp::sub(s[0], half_w)) <= guard && wp::abs(wp::sub(s[1], half_h)) <= guard;
    }};
    const bool fast = !reject && front && inside(s0) && inside(s1) && inside(s2);
    slow[j] = !reject && !fast;
    // (the snap of a lane that is not fast reads zeros, so its conversions stay in range)
    const wp::vec3 a = fast ? s0 : wp::vec3(0.0f), b = fast ? s1 : wp::vec3(0.0f), c = fast ? s2 : wp::vec3(0.0f);
    const int64_t pax = fixed(a[0]) + shift_x, pay = fixed(a[1]) + shift_y;
    int64_t pbx = fixed(b[0]) + shift_x, pby = fixed(b[1]) + shift_y;
    int64_t pcx = fixed(c[0]) + shift_x, pcy = fixed(c[1]) + shift_y;
    float pzb = b[2], pzc = c[2];
    int64_t ar = (pbx - pax) * (pcy - pay) - (pby - pay) * (pcx - pax);
    const bool flip = ar < 0;
    const int64_t tx = pbx, ty = pby;
    const float tz = pzb;
    pbx = flip ? pcx : pbx; pby = flip ? pcy : pby; pzb = flip ? pzc : pzb;
    pcx = flip ? tx : pcx; pcy = flip ? ty : pcy; pzc = flip ? tz : pzc;
    ar = flip ? -ar : ar;
    int x0 = (int)((wp::min(wp::min(pax, pbx), pcx) + HALF_SUB - 1) >> 8);
    int x1 = (int)((wp::max(wp::max(pax, pbx), pcx) - HALF_SUB) >> 8);
    int y0 = (int)((wp::min(wp::min(pay, pby), pcy) + HALF_SUB - 1) >> 8);
    int y1 = (int)((wp::max(wp::max(pay, pby), pcy) - HALF_SUB) >> 8);
    x0 = wp::max(x0, 0);
    y0 = wp::max(y0, target.row_begin);
    x1 = wp::min(x1, cam.width - 1);
    y1 = wp::min(y1, target.row_end - 1);
    live[j] = fast && ar != 0 && x0 <= x1 && y0 <= y1;
    ax[j] = pax; ay[j] = pay; bx[j] = pbx; by[j] = pby; cx[j] = pcx; cy[j] = pcy; area[j] = ar;
    za[j] = a[2]; zb[j] = pzb; zc[j] = pzc;
    bx0[j] = x0; bx1[j] = x1; by0[j] = y0; by1[j] = y1;
}}
uint64_t left = 0;
for (int j = 0; j < n; ++j) left |= slow[j] ? (uint64_t)1 << j : (uint64_t)0;
auto fill_bias = [&](const int64_t dx, const int64_t dy) -> int64_t {{
    return (dy < 0 || (dy == 0 && dx > 0)) ? (int64_t)0 : (int64_t)-1;
}};
auto inv_step = [&](const int64_t step) -> float {{ return step == 0 ? 0.0f : wp::div(1.0f, (float)step); }};
// narrow the pixel-offset interval [lo, hi] to where w + k step >= 0 (``coverage._span``)
auto narrow = [&](const int64_t w, const int64_t step, const float inv, const float span_max, float& lo, float& hi) {{
    if (step == 0) {{
        if (w < 0) {{ lo = 1.0f; hi = 0.0f; }}
        return;
    }}
    const float r = wp::clamp(wp::mul(wp::neg((float)w), inv), -2.0f, span_max);
    if (step > 0) lo = wp::max(lo, wp::sub(wp::floor(r), 1.0f));
    else hi = wp::min(hi, wp::add(wp::ceil(r), 1.0f));
}};
char* const keys = (char*)target.keys.data + (size_t)target.slot * target.keys.strides[0];
for (int j = 0; j < n; ++j) {{
    if (!live[j]) continue;
    const int tri = first + j;
    if ((scene.materials.data[scene.triangle_material.data[tri]].flags & {int(FLAG_CUTOUT)}) != 0) {{
        left |= (uint64_t)1 << j;
        continue;
    }}
    const int64_t pax = ax[j], pay = ay[j], pbx = bx[j], pby = by[j], pcx = cx[j], pcy = cy[j];
    const int x0 = bx0[j], x1 = bx1[j];
    const int64_t bias_a = fill_bias(pcx - pbx, pcy - pby);
    const int64_t bias_b = fill_bias(pax - pcx, pay - pcy);
    const int64_t bias_c = fill_bias(pbx - pax, pby - pay);
    const int64_t step_a = (pby - pcy) * SUB, step_b = (pcy - pay) * SUB, step_c = (pay - pby) * SUB;
    const float inv_za = wp::div(1.0f, za[j]), inv_zb = wp::div(1.0f, zb[j]), inv_zc = wp::div(1.0f, zc[j]);
    const float farea = (float)area[j];
    const float min_denom = wp::div(farea, far);
    const bool wide = x1 - x0 >= {int(NARROW_PX)};
    const float span_max = (float)(x1 - x0 + 2);
    const float inv_sa = wide ? inv_step(step_a) : 0.0f;
    const float inv_sb = wide ? inv_step(step_b) : 0.0f;
    const float inv_sc = wide ? inv_step(step_c) : 0.0f;
    const int64_t px0 = (int64_t)x0 * SUB + HALF_SUB;
    const uint64_t id = (uint64_t)tri;
    // a pixel's perspective denominator from its edge values, and its depth key
    auto denom_at = [&](const int64_t a, const int64_t b, const int64_t c) -> float {{
        return wp::add(wp::add(wp::mul((float)a, inv_za), wp::mul((float)b, inv_zb)), wp::mul((float)c, inv_zc));
    }};
    auto depth_key = [&](const float denom) -> uint64_t {{
        return ((uint64_t)__builtin_bit_cast(unsigned int, wp::div(farea, denom)) << 32) | id;
    }};
    // the edge values at the sample point (px, py), in 1/256 px (exact integers)
    auto edges = [&](const int64_t px, const int64_t py, int64_t& a, int64_t& b, int64_t& c) {{
        a = (pcx - pbx) * (py - pby) - (pcy - pby) * (px - pbx) + bias_a;
        b = (pax - pcx) * (py - pcy) - (pay - pcy) * (px - pcx) + bias_b;
        c = (pbx - pax) * (py - pay) - (pby - pay) * (px - pax) + bias_c;
    }};
    if (!wide && target.mode == {int(MODE_DEPTH)} && target.keys.strides[2] == sizeof(uint64_t) &&
        x0 + TILE <= (int)target.keys.shape[2]) {{
        // a narrow box (its columns fit a tile's): TILE rows at a time, the tile's pixel
        // centres across lanes (each its edge values as the row loop below steps them, exact
        // integers, and the same depth arithmetic), then the tile's keys in the box's rows
        // read and written back, lowered where covered (this thread's rows alone; a column
        // past the box lies outside the triangle, so it keeps its key)
        for (int ty = by0[j]; ty <= by1[j]; ty += TILE) {{
            bool covered[TILE * TILE];
            uint64_t values[TILE * TILE];
            #pragma clang loop vectorize(enable)
            for (int q = 0; q < TILE * TILE; ++q) {{
                const int64_t px = px0 + (int64_t)(q % TILE) * SUB;
                const int64_t py = (int64_t)(ty + q / TILE) * SUB + HALF_SUB;
                int64_t a, b, c;
                edges(px, py, a, b, c);
                const float denom = denom_at(a, b, c);
                covered[q] = (a | b | c) >= 0 && denom >= min_denom;
                values[q] = depth_key(denom);
            }}
            const int rows = wp::min(TILE, by1[j] - ty + 1);
            for (int r = 0; r < rows; ++r) {{
                uint64_t* const span = (uint64_t*)(keys + (size_t)(ty + r) * target.keys.strides[1]) + x0;
                for (int k = 0; k < TILE; ++k) {{
                    const int q = TILE * r + k;
                    const uint64_t old = span[k];
                    span[k] = covered[q] && values[q] < old ? values[q] : old;
                }}
            }}
        }}
        continue;
    }}
    for (int y = by0[j]; y <= by1[j]; ++y) {{
        const int64_t py = (int64_t)y * SUB + HALF_SUB;
        int64_t wa, wb, wc;
        edges(px0, py, wa, wb, wc);
        int lo = 0, hi = x1 - x0;
        if (wide) {{
            float slo = 0.0f, shi = span_max;
            narrow(wa, step_a, inv_sa, span_max, slo, shi);
            narrow(wb, step_b, inv_sb, span_max, slo, shi);
            narrow(wc, step_c, inv_sc, span_max, slo, shi);
            lo = wp::max((int)slo, 0);
            hi = wp::min((int)shi, x1 - x0);
            wa += (int64_t)lo * step_a;
            wb += (int64_t)lo * step_b;
            wc += (int64_t)lo * step_c;
        }}
        char* const row = keys + (size_t)y * target.keys.strides[1];
        if (wide && target.mode == {int(MODE_DEPTH)} && target.keys.strides[2] == sizeof(uint64_t)) {{
            // a wide row's span across lanes: each pixel's edge values as the loop below
            // steps them (exact integers), the same depth arithmetic, and its key read
            // and written back, kept or lowered (this thread's rows alone)
            uint64_t* const span = (uint64_t*)row + x0;
            #pragma clang loop vectorize(enable)
            for (int k = lo; k <= hi; ++k) {{
                const int64_t a = wa + (int64_t)(k - lo) * step_a;
                const int64_t b = wb + (int64_t)(k - lo) * step_b;
                const int64_t c = wc + (int64_t)(k - lo) * step_c;
                const float denom = denom_at(a, b, c);
                const bool covered = (a | b | c) >= 0 && denom >= min_denom;
                const uint64_t value = depth_key(denom);
                const uint64_t old = span[k];
                span[k] = covered && value < old ? value : old;
            }}
            continue;
        }}
        for (int k = lo; k <= hi; ++k) {{
            if ((wa | wb | wc) >= 0) {{
                const float denom = denom_at(wa, wb, wc);
                if (denom >= min_denom) {{
                    uint64_t* key = (uint64_t*)(row + (size_t)(x0 + k) * target.keys.strides[2]);
                    if (target.mode == {int(MODE_DEPTH)}) {{
                        const uint64_t value = depth_key(denom);
                        *key = value < *key ? value : *key;
                    }} else {{
                        *key += 1;
                    }}
                }}
            }}
            wa += step_a;
            wb += step_b;
            wc += step_c;
        }}
    }}
}}
return left;
#endif
"""


@wp.func_native(_COVER_BATCH_CPP)
def cover_batch(
    scene: SceneGPU, cam: CameraGPU, pts: ProjectedPoints, target: RasterTarget, first: int, stop: int
) -> wp.uint64:
    """Triangles ``first <= t < stop`` (at most ``BATCH_TRIANGLES``) rasterized into
    ``target`` where each lies in front of the near plane inside the guard band and is
    not cut out (the same keys as ``coverage.raster_triangle``); returns the mask of the
    others that the trivial rejects keep (bit ``t - first``), for the Warp path."""
    ...
