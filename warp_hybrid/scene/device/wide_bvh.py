"""A 4-wide BVH over a ``wp.Mesh``'s triangles for the CPU tracer: four children to a
node tested at once, and each leaf's triangles stored in order beside it.

Warp's CPU ray queries walk a binary tree: each step loads two children and tests two
boxes, and each leaf triangle is reached through two index lookups (the leaf's
primitive list, then the mesh's vertex indices).  ``WideBVH`` builds a binary SAH tree
of its own over the mesh's triangles and collapses it into nodes of up to four children
(``wide_bvh_build.py``), whose boxes are stored as six 4-lane rows (low and high x, y,
z) beside its four children in 128 bytes, so one node is two cache lines and one 4-wide
slab test (clang vector extensions, SSE on any x86-64),
and copies each leaf's triangle corners into one array in leaf order, four triangles to a
group, each axis of each corner a row of four lanes (a leaf starts a group; the spare
slots of its last group repeat that group's first triangle), so a group's part of the
triangle test loads nine 4-lane vectors (``grouped_leaves``; 5-22% less time a single-ray
query on the staircase's and the glass dragon's rays, docs/speed_journal.md, "The textured
dome's texel reads taken apart, leaf triangles a lane each").  Leaves keep
Warp's triangles and its watertight triangle test (``intersect_ray_tri_woop``), the
ray's part of it once per ray and the triangle's part for four of a leaf's triangles at
once, each lane Warp's arithmetic operation for operation, so the answers are Warp's
whatever the tree: the same face, distance and barycentrics
(``tests/scene/device/test_wide_bvh.py``); where two triangles are hit at exactly the
same distance (a shared edge) the one first in the tree's leaf order is the answer, which
may be the other one than Warp's.

``wide_closest`` is ``wp.mesh_query_ray`` (nearest hit, children visited near first,
a child skipped once its entry distance is past the nearest hit); ``wide_any_hit`` is
``wp.mesh_query_ray_anyhit``; ``wide_any_hit_packet`` answers ``PACKET`` rays' any-hits
at once, each ray's answer ``wide_any_hit``'s (the primary shadow pass's query: a row of
pixels' rays toward one light share the nodes they visit), and ``wide_closest_packet``
their nearest hits, each ``wide_closest``'s bit for bit (the path kernel's first rays).  The slab test widens its far distance by
``1 + 2 gamma(3)`` (pbrt-v4's robust ray-box test), so rounding never culls a box the
ray touches, and an axis the ray does not move along tests the origin against the slab
(as Warp's robust test does), so rays along a box's face still enter it.  Measured on
the staircase (262k triangles, one thread, 640x480 G-buffer points): a mirror ray's
closest hit 1242 ns with Warp's query, 498 ns with this one over Warp's own tree; a
shadow ray's any-hit 913 ns and 315 ns (README, "4-wide BVH copies"); the tree of its own
made both another 1.1-1.3x faster (docs/speed_journal.md, "Re-measured on the AMD EPYC
machine (2026-12-03)").

CPU only: the tracer's CUDA variant keeps Warp's own queries (``TraceVariant.wide_bvh``),
and the native code compiles to a stub under ``__CUDA_ARCH__``.  The scene's own copy is
``DeviceScene.wide_bvh`` (built on first use); the tracer's shadow BVHs have theirs
(``trace/occluders.py``); the ray-cast primaries (``--primary raycast``, the fovea
sampler's window samples) query the scene's copy too.  ``use_wide_bvh`` is the one rule
for whether a pass queries the copies.  After the mesh's points move (animated points)
``refit`` copies the new corners and computes the boxes again (given the points that
moved, only theirs and the boxes above them); the tree's shape does not change on a refit.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ...errors import RenderSettingsError
from .wide_bvh_build import (
    CHILD_LANES,
    MAX_DEPTH,
    MAX_LEAF,
    NO_CHILD_C,
    NODE_FLOATS,
    build_kernel,
    collapse_kernel,
    refit_kernel,
    slot_lane_cpp,
)

#: Children per node.
WIDTH = 4
#: The traversal stack: up to three entries pushed a level (the nearest child is taken
#: at once), and the 4-wide tree is no deeper than the binary one it collapses
#: (``wide_bvh_build.MAX_DEPTH`` levels), so the stack never fills.
STACK_SIZE = 3 * (MAX_DEPTH + 1)


@wp.struct
class WideBVHGPU:
    """The kernel-side tree.  ``node_data``: ``NODE_FLOATS`` (32) floats a node, 128 bytes
    (two cache lines, one load of a node): its four children's boxes (low x, y, z then
    high x, y, z, 4 lanes each; 24 floats), then from ``CHILD_LANES`` the four children
    as int32 bits (>= 0 a node, ``-(leaf + 1)`` a leaf, ``NO_CHILD`` none), then 4
    unused; ``leaves``: 2 a leaf (first and end slot; ``grouped_leaves``); ``corners``: 36
    floats a group of four slots, slot k's corner c, axis a at ``9 (k & ~3) + 4 (3 c + a)
    + (k & 3)``; ``faces``: the mesh's face of each slot; ``nodes``: 0 for an empty mesh
    (every query misses)."""

    node_data: wp.array(dtype=wp.float32)
    leaves: wp.array(dtype=wp.int32)
    corners: wp.array(dtype=wp.float32)
    faces: wp.array(dtype=wp.int32)
    nodes: int


# The children a node's ray enters (one vector test of the four lanes), nearest first (a
# tie: the lower lane), taken or pushed; two spellings of the one rule, each where it
# measured faster (README, "4-wide BVH copies"): sorted lane by lane for the closest hit,
# from the mask's bits for the any-hit (7-11% faster shadow rays there, 4-15% slower
# closest hits).
_ENTER_BY_LANE = """const int* c = (const int*)(b + CHILD_LANES);
        const v4i entered = (*(const v4i*)c != none) & (near_t <= far_t) & (near_t <= best);
        int hit_c[4];
        float hit_t[4];
        int hits = 0;
        for (int j = 0; j < 4; ++j) {
            if (entered[j]) {
                int q = hits++;
                while (q > 0 && hit_t[q - 1] > near_t[j]) { hit_t[q] = hit_t[q - 1]; hit_c[q] = hit_c[q - 1]; --q; }
                hit_t[q] = near_t[j];
                hit_c[q] = c[j];
            }
        }
        if (hits == 0) { cur = none; break; }
        if (sp + hits - 1 > STACK) { cur = none; sp = 0; break; }
        for (int q = hits - 1; q >= 1; --q) { stack[sp] = hit_c[q]; stack_t[sp] = hit_t[q]; ++sp; }
        cur = hit_c[0];"""

_ENTER_BY_MASK = """const int* c = (const int*)(b + CHILD_LANES);
        const v4i entered = (*(const v4i*)c != none) & (near_t <= far_t) & (near_t <= best);
        int bits = __builtin_reduce_or(entered & (v4i){1, 2, 4, 8});
        if (bits == 0) { cur = none; break; }
        const int first = __builtin_ctz(bits);
        bits &= bits - 1;
        if (bits == 0) { cur = c[first]; continue; }  // one child entered: no push
        const int second = __builtin_ctz(bits);
        bits &= bits - 1;
        if (bits == 0) {  // two: the nearer first, the other pushed
            if (sp + 1 > STACK) { cur = none; sp = 0; break; }
            const bool swap = near_t[second] < near_t[first];
            const int near_j = swap ? second : first, far_j = swap ? first : second;
            stack[sp] = c[far_j]; stack_t[sp] = near_t[far_j]; ++sp;
            cur = c[near_j];
            continue;
        }
        int hit_c[4];
        float hit_t[4];
        int hits = 0;
        for (int j = first; j < 4; ++j) {  // three or four: sorted by insertion, stable in lane order
            if (entered[j]) {
                int q = hits++;
                while (q > 0 && hit_t[q - 1] > near_t[j]) { hit_t[q] = hit_t[q - 1]; hit_c[q] = hit_c[q - 1]; --q; }
                hit_t[q] = near_t[j];
                hit_c[q] = c[j];
            }
        }
        if (sp + hits - 1 > STACK) { cur = none; sp = 0; break; }
        for (int q = hits - 1; q >= 1; --q) { stack[sp] = hit_c[q]; stack_t[sp] = hit_t[q]; ++sp; }
        cur = hit_c[0];"""


# The pieces of the traversal both queries share, so the single-ray query and the packet
# test a ray alike: the axis permutation of Warp's watertight test for direction DIR; the
# entry and exit distances of slabs t0/t1 (vector type VF); and the watertight test's
# triangle part over the lanes of VF/VI vectors (four triangles of one ray, or one
# triangle for PACKET rays; lanes below USED are real), each lane Warp's scalar
# operations, ending with the lanes kept and their distances ``tt`` (a lane-free group
# ``continue``s its loop).
#: The slab test's far-distance factor, 1 + 2 gamma(3) (pbrt-v4's robust ray-box test).
_WIDEN = "1.0f + 2.0f * (3.0f * 5.96046448e-08f) / (1.0f - 3.0f * 5.96046448e-08f)"
_RAY_AXES = """int kz = wp::max_dim(DIR);
int kx = kz + 1;
if (kx == 3) kx = 0;
int ky = kx + 1;
if (ky == 3) ky = 0;
if (DIR[kz] < 0.0f) { const int tmp = kx; kx = ky; ky = tmp; }
"""
_SLAB_SPAN = """const VF near_t = __builtin_elementwise_max(
    __builtin_elementwise_max(__builtin_elementwise_min(t0x, t1x), __builtin_elementwise_min(t0y, t1y)),
    __builtin_elementwise_max(__builtin_elementwise_min(t0z, t1z), (VF)0.0f));
const VF far_t = __builtin_elementwise_min(
    __builtin_elementwise_min(__builtin_elementwise_max(t0x, t1x), __builtin_elementwise_max(t0y, t1y)),
    __builtin_elementwise_max(t0z, t1z)) * widen;
"""
_WATERTIGHT_LANES = """const VF ax = Ax - Sx * Az, ay = Ay - Sy * Az;
const VF bx = Bx - Sx * Bz, by = By - Sy * Bz;
const VF cx = Cx - Sx * Cz, cy = Cy - Sy * Cz;
auto diff_product = [](VF a, VF b, VF c, VF e) {
    const VF ce = c * e;
    return __builtin_elementwise_fma(a, b, -ce) + __builtin_elementwise_fma(-c, e, ce);
};
VF U = diff_product(cx, by, cy, bx);
VF V = diff_product(ax, cy, ay, cx);
VF W = diff_product(bx, ay, by, ax);
// Warp's fallback where an edge function is exactly zero: the products in double
const VI zero = (U == 0.0f) | (V == 0.0f) | (W == 0.0f);
if (__builtin_reduce_or(zero)) {
    for (int j = 0; j < USED; ++j) {
        if (zero[j]) {
            U[j] = (float)((double)cx[j] * (double)by[j] - (double)cy[j] * (double)bx[j]);
            V[j] = (float)((double)ax[j] * (double)cy[j] - (double)ay[j] * (double)cx[j]);
            W[j] = (float)((double)bx[j] * (double)ay[j] - (double)by[j] * (double)ax[j]);
        }
    }
}
const VI outside = ((U < 0.0f) | (V < 0.0f) | (W < 0.0f)) & ((U > 0.0f) | (V > 0.0f) | (W > 0.0f));
const VF det = U + V + W;
const VF az = Sz * Az, bz = Sz * Bz, cz = Sz * Cz;
const VF T = U * az + V * bz + W * cz;
// wp::xorf(T, wp::sign_mask(det)) < 0: T carrying det's sign bit, compared as a float
const VI det_sign = __builtin_bit_cast(VI, det) & (int)0x80000000;
const VI behind = __builtin_bit_cast(VF, __builtin_bit_cast(VI, T) ^ det_sign) < 0.0f;
VI keep = ~outside & (det != 0.0f) & ~behind;
if (!__builtin_reduce_or(keep)) continue;
const VF rcp = 1.0f / det;
const VF tt = T * rcp;
"""


def _lanes(snippet: str, vf: str, vi: str, used: str) -> str:
    """``snippet`` with its vector types and its count of real lanes filled in."""
    return snippet.replace("VF", vf).replace("VI", vi).replace("USED", used)


# The traversal shared by both queries (``if (ANY) return HIT;`` is the any-hit's early
# exit); ``ENTER_CHILDREN`` is one of the two spellings above.
_TRAVERSE = """
#if defined(__CUDA_ARCH__)
return MISS;
#else
typedef float v4f __attribute__((ext_vector_type(4)));
typedef int v4i __attribute__((ext_vector_type(4)));
if (nodes <= 0) return MISS;
const float* nb = node_data.data;
const int* lv = leaves.data;
const float* tv = corners.data;
// An axis the ray does not move along: the ray is in a box's slab for every t when its
// origin is (lanes: -FLT_MAX, FLT_MAX), else never (FLT_MAX twice), as Warp's robust test.
const bool flat_x = wp::abs(d[0]) < 1.0e-30f, flat_y = wp::abs(d[1]) < 1.0e-30f, flat_z = wp::abs(d[2]) < 1.0e-30f;
const v4f ox = o[0], oy = o[1], oz = o[2];
const v4f ix = flat_x ? 0.0f : 1.0f / d[0], iy = flat_y ? 0.0f : 1.0f / d[1], iz = flat_z ? 0.0f : 1.0f / d[2];
auto flat_slab = [](v4f& t0, v4f& t1, const float* lo, const float* hi, float origin) {
    for (int j = 0; j < 4; ++j) {
        const bool in = lo[j] <= origin && origin <= hi[j];
        t0[j] = in ? -FLT_MAX : FLT_MAX;
        t1[j] = FLT_MAX;
    }
};
const float widen = WIDEN;
// Warp's watertight triangle test (wp::intersect_ray_tri_woop), its ray part once per ray
// (the axis permutation and shear) and its triangle part for a group of four triangles of a
// leaf at a time (its corners' axes loaded as 4-lane rows), each lane the same operations as
// Warp's scalar code, so each lane's answer is Warp's.
RAY_AXES
const float Sx = d[kx] / d[kz];
const float Sy = d[ky] / d[kz];
const float Sz = 1.0f / d[kz];
const int none = NO_CHILD;
float best = max_t;
int best_k = -1;
float best_u = 0.0f, best_v = 0.0f;
int stack[STACK];
float stack_t[STACK];
int sp = 0;
int cur = 0;
while (true) {
    while (cur >= 0) {
        const float* b = nb + NODE_FLOATS * cur;
        v4f t0x = (*(const v4f*)(b + 0) - ox) * ix, t1x = (*(const v4f*)(b + 12) - ox) * ix;
        v4f t0y = (*(const v4f*)(b + 4) - oy) * iy, t1y = (*(const v4f*)(b + 16) - oy) * iy;
        v4f t0z = (*(const v4f*)(b + 8) - oz) * iz, t1z = (*(const v4f*)(b + 20) - oz) * iz;
        if (flat_x) flat_slab(t0x, t1x, b + 0, b + 12, o[0]);
        if (flat_y) flat_slab(t0y, t1y, b + 4, b + 16, o[1]);
        if (flat_z) flat_slab(t0z, t1z, b + 8, b + 20, o[2]);
SLAB_SPAN
        ENTER_CHILDREN
    }
    if (cur != none) {
        const int leaf = -cur - 1;
        const int leaf_end = lv[2 * leaf + 1];
        for (int g = lv[2 * leaf]; g < leaf_end; g += 4) {
            const int n = leaf_end - g < 4 ? leaf_end - g : 4;
            // the group's corners, one vector an axis of a corner (a spare lane repeats the first)
            const float* t = tv + 9 * g;
            const v4f Ax = *(const v4f*)(t + 4 * kx) - o[kx], Ay = *(const v4f*)(t + 4 * ky) - o[ky];
            const v4f Az = *(const v4f*)(t + 4 * kz) - o[kz];
            const v4f Bx = *(const v4f*)(t + 12 + 4 * kx) - o[kx], By = *(const v4f*)(t + 12 + 4 * ky) - o[ky];
            const v4f Bz = *(const v4f*)(t + 12 + 4 * kz) - o[kz];
            const v4f Cx = *(const v4f*)(t + 24 + 4 * kx) - o[kx], Cy = *(const v4f*)(t + 24 + 4 * ky) - o[ky];
            const v4f Cz = *(const v4f*)(t + 24 + 4 * kz) - o[kz];
WATERTIGHT_LANES
            keep &= (tt <= best) & (tt >= 0.0f);
            if (!__builtin_reduce_or(keep)) continue;
            for (int j = 0; j < n; ++j) {  // the nearest; at equal distances the first in leaf order
                if (keep[j] && (tt[j] < best || (tt[j] == best && g + j < best_k))) {
                    if (ANY) return HIT;
                    best = tt[j]; best_k = g + j; best_u = U[j] * rcp[j]; best_v = V[j] * rcp[j];
                }
            }
        }
    }
    cur = none;
    while (sp > 0) {
        --sp;
        if (stack_t[sp] <= best) { cur = stack[sp]; break; }
    }
    if (cur == none) break;
}
if (best_k < 0) return MISS;
return FOUND;
#endif
"""


def _traversal(enter_children: str) -> str:
    """``_TRAVERSE`` with ``enter_children`` (one of the two spellings) and the constants."""
    return (
        _TRAVERSE.replace("RAY_AXES", _RAY_AXES.replace("DIR", "d"))
        .replace("WIDEN", _WIDEN)
        .replace("SLAB_SPAN", _lanes(_SLAB_SPAN, "v4f", "v4i", "4"))
        .replace("WATERTIGHT_LANES", _lanes(_WATERTIGHT_LANES, "v4f", "v4i", "n"))
        .replace("ENTER_CHILDREN", enter_children)
        .replace("STACK", str(STACK_SIZE))
        .replace("NODE_FLOATS", str(NODE_FLOATS))
        .replace("CHILD_LANES", str(CHILD_LANES))
        .replace("NO_CHILD", NO_CHILD_C)
    )


#: (face, t, u, v, normal x, y, z, 1) of a hit; all -1 for none.
_hit8 = wp.types.vector(length=8, dtype=wp.float32)

# The row of a hit on slot k at distance t, barycentrics u, v (``_hit8``): its mesh face and
# the unit normal of its corners (read from the slot's lane of its group), for both closest
# queries (defined after ``tv``).
_HIT_ROW_CPP = """
auto wh_hit_row = [&](const int k, const float t, const float u, const float v) -> wp::vec_t<8, float> {
    const float* c = tv + SLOT_K;
    const wp::vec3 a(c[0], c[4], c[8]);
    const wp::vec3 n = wp::normalize(wp::cross(wp::vec3(c[12], c[16], c[20]) - a, wp::vec3(c[24], c[28], c[32]) - a));
    wp::vec_t<8, float> r;
    r[0] = (float)faces.data[k]; r[1] = t; r[2] = u; r[3] = v; r[4] = n[0]; r[5] = n[1]; r[6] = n[2]; r[7] = 1.0f;
    return r;
};
"""

_CLOSEST = (
    _traversal(_ENTER_BY_LANE)
    .replace("MISS", "wp::vec_t<8, float>(-1.0f)")
    .replace("if (ANY) return HIT;", "")
    .replace("const float* tv = corners.data;", "const float* tv = corners.data;" + _HIT_ROW_CPP)
    .replace("SLOT_K", slot_lane_cpp("k"))
    .replace("FOUND", "wh_hit_row(best_k, best, best_u, best_v)")
)

_ANY = (
    _traversal(_ENTER_BY_MASK)
    .replace("MISS", "false")
    .replace("if (ANY) return HIT;", "return true;")
    .replace("FOUND", "true")
)


@wp.func_native(_CLOSEST)
def _closest(
    node_data: wp.array(dtype=wp.float32),
    leaves: wp.array(dtype=wp.int32),
    corners: wp.array(dtype=wp.float32),
    faces: wp.array(dtype=wp.int32),
    nodes: int,
    o: wp.vec3,
    d: wp.vec3,
    max_t: float,
) -> _hit8: ...


@wp.func_native(_ANY)
def _any(
    node_data: wp.array(dtype=wp.float32),
    leaves: wp.array(dtype=wp.int32),
    corners: wp.array(dtype=wp.float32),
    faces: wp.array(dtype=wp.int32),
    nodes: int,
    o: wp.vec3,
    d: wp.vec3,
    max_t: float,
) -> bool: ...


#: Rays in a packet of ``wide_any_hit_packet``.
PACKET = 8
_packet_points = wp.types.matrix(shape=(PACKET, 3), dtype=wp.float32)
_packet_floats = wp.types.vector(length=PACKET, dtype=wp.float32)

# The packet queries: PACKET rays at once, each node's children tested one box at a time
# against every ray of the packet still in play that entered the node (the box test and,
# in the leaves, Warp's watertight triangle test, lane for lane the same operations as the
# single-ray queries above, so each ray gets the same answer).  Pieces both share:
# _PACKET_RAYS, the rays' part of both tests across the lanes (``MISS`` for an empty
# tree); _PACKET_BOX, child j's entry and exit distances for every lane (box pointer b);
# _PACKET_CORNERS, triangle g's corners relative to each ray's origin, permuted by its own
# dominant axis (broadcast once for a packet whose rays share one, the common case, lane
# by lane otherwise).  Every level pushes at most three children, as the single-ray
# query, so the stack of STACK entries never fills.
_PACKET_RAYS = """typedef float vPf __attribute__((ext_vector_type(PACKET)));
typedef int vPi __attribute__((ext_vector_type(PACKET)));
if (nodes <= 0) return MISS;
const float* nb = node_data.data;
const int* lv = leaves.data;
const float* tv = corners.data;
const float widen = WIDEN;
// the rays' part of the slab and watertight tests, across the packet's lanes: the same
// operations as the single-ray query's (RAY_AXES as selects: Warp's max_dim keeps the first
// of equal extents), so each lane's values are that query's
vPf ox, oy, oz, dx, dy, dz, tmax;
for (int j = 0; j < PACKET; ++j) {
    ox[j] = o.data[j][0]; oy[j] = o.data[j][1]; oz[j] = o.data[j][2];
    dx[j] = d.data[j][0]; dy[j] = d.data[j][1]; dz[j] = d.data[j][2];
    tmax[j] = max_t[j];
}
const vPf adx = __builtin_elementwise_abs(dx), ady = __builtin_elementwise_abs(dy), adz = __builtin_elementwise_abs(dz);
const vPi flat_x = adx < 1.0e-30f, flat_y = ady < 1.0e-30f, flat_z = adz < 1.0e-30f;
const vPf ix = flat_x ? (vPf)0.0f : 1.0f / dx, iy = flat_y ? (vPf)0.0f : 1.0f / dy, iz = flat_z ? (vPf)0.0f : 1.0f / dz;
const vPi y_longer = ady > adx;
const vPi kz = adz > (y_longer ? ady : adx) ? (vPi)2 : (y_longer ? (vPi)1 : (vPi)0);
auto pick = [](const vPi k, const vPf x, const vPf y, const vPf z) { return k == 0 ? x : (k == 1 ? y : z); };
const vPf dkz = pick(kz, dx, dy, dz);
const vPi kx_turn = kz == 2 ? (vPi)0 : kz + 1;
const vPi ky_turn = kx_turn == 2 ? (vPi)0 : kx_turn + 1;
const vPi swap = dkz < 0.0f;
const vPi kx = swap ? ky_turn : kx_turn, ky = swap ? kx_turn : ky_turn;
const vPf Sx = pick(kx, dx, dy, dz) / dkz, Sy = pick(ky, dx, dy, dz) / dkz, Sz = 1.0f / dkz;
const vPf okx = pick(kx, ox, oy, oz), oky = pick(ky, ox, oy, oz), okz = pick(kz, ox, oy, oz);
vPi lane_bit;
for (int j = 0; j < PACKET; ++j) lane_bit[j] = 1 << j;
// the single-ray query finds nothing for max_t <= 0 (or NaN)
const unsigned live = (unsigned)__builtin_reduce_or((tmax > 0.0f) & lane_bit);
// the rays' shared dominant axis, if the live rays have one (lanes without a ray ignored)
const int lead = live != 0 ? __builtin_ctz(live) : 0;
const unsigned same = (unsigned)__builtin_reduce_or((kx == kx[lead]) & (ky == ky[lead]) & (kz == kz[lead]) & lane_bit);
const bool uniform = (same & live) == live;
const bool any_flat = __builtin_reduce_or(flat_x | flat_y | flat_z) != 0;
"""
_PACKET_BOX = """vPf t0x = (b[0 + j] - ox) * ix, t1x = (b[12 + j] - ox) * ix;
vPf t0y = (b[4 + j] - oy) * iy, t1y = (b[16 + j] - oy) * iy;
vPf t0z = (b[8 + j] - oz) * iz, t1z = (b[20 + j] - oz) * iz;
if (any_flat) {
    const vPi in_x = (b[0 + j] <= ox) & (ox <= b[12 + j]);
    const vPi in_y = (b[4 + j] <= oy) & (oy <= b[16 + j]);
    const vPi in_z = (b[8 + j] <= oz) & (oz <= b[20 + j]);
    t0x = flat_x ? (in_x ? (vPf)-FLT_MAX : (vPf)FLT_MAX) : t0x; t1x = flat_x ? (vPf)FLT_MAX : t1x;
    t0y = flat_y ? (in_y ? (vPf)-FLT_MAX : (vPf)FLT_MAX) : t0y; t1y = flat_y ? (vPf)FLT_MAX : t1y;
    t0z = flat_z ? (in_z ? (vPf)-FLT_MAX : (vPf)FLT_MAX) : t0z; t1z = flat_z ? (vPf)FLT_MAX : t1z;
}
SLAB_SPAN
"""
_PACKET_CORNERS = """const float* t = tv + SLOT_G;  // triangle g's lane of its group
vPf Ax, Ay, Az, Bx, By, Bz, Cx, Cy, Cz;
if (uniform) {
    const int ux = 4 * kx[lead], uy = 4 * ky[lead], uz = 4 * kz[lead];
    Ax = t[ux] - okx; Ay = t[uy] - oky; Az = t[uz] - okz;
    Bx = t[12 + ux] - okx; By = t[12 + uy] - oky; Bz = t[12 + uz] - okz;
    Cx = t[24 + ux] - okx; Cy = t[24 + uy] - oky; Cz = t[24 + uz] - okz;
} else {
    for (int j = 0; j < PACKET; ++j) {
        const int ux = 4 * kx[j], uy = 4 * ky[j], uz = 4 * kz[j];
        Ax[j] = t[ux] - okx[j]; Ay[j] = t[uy] - oky[j]; Az[j] = t[uz] - okz[j];
        Bx[j] = t[12 + ux] - okx[j]; By[j] = t[12 + uy] - oky[j]; Bz[j] = t[12 + uz] - okz[j];
        Cx[j] = t[24 + ux] - okx[j]; Cy[j] = t[24 + uy] - oky[j]; Cz[j] = t[24 + uz] - okz[j];
    }
}
"""

# The any-hit query: a child is taken or pushed with the mask of the rays that enter it,
# in lane order; a ray leaves the packet once blocked.
_ANY_PACKET = """
#if defined(__CUDA_ARCH__)
return 0;
#else
PACKET_RAYS
const int none = NO_CHILD;
unsigned blocked = 0;
int stack[STACK];
unsigned stack_m[STACK];
int sp = 0;
if (live != 0) { stack[0] = 0; stack_m[0] = live; sp = 1; }
while (sp > 0) {
    --sp;
    int cur = stack[sp];
    unsigned m = stack_m[sp] & ~blocked;
    if (m == 0) continue;
    while (cur >= 0) {  // down the tree: the first child entered taken, the others pushed
        const float* b = nb + NODE_FLOATS * cur;
        const int* c = (const int*)(b + CHILD_LANES);
        int next = none;
        unsigned next_m = 0;
        for (int j = 0; j < 4; ++j) {
            if (c[j] == none) continue;
PACKET_BOX
            const unsigned em = (unsigned)__builtin_reduce_or((near_t <= far_t) & (near_t <= tmax) & lane_bit) & m;
            if (em == 0) continue;
            if (next == none) { next = c[j]; next_m = em; }
            else { stack[sp] = c[j]; stack_m[sp] = em; ++sp; }
        }
        cur = next;
        m = next_m;
    }
    if (cur == none) continue;
    const int leaf = -cur - 1;
    const int leaf_end = lv[2 * leaf + 1];
    for (int g = lv[2 * leaf]; g < leaf_end && (m & ~blocked) != 0; ++g) {
PACKET_CORNERS
WATERTIGHT_LANES
        keep &= (tt < tmax) & (tt >= 0.0f);
        blocked |= (unsigned)__builtin_reduce_or(keep & lane_bit) & m;
    }
}
return (int)blocked;
#endif
"""

# The closest-hit query: each ray's nearest hit so far in ``best`` (its leaf-order index
# ``best_k``, the same (distance, index) rule as ``_closest``, so the order the packet
# visits the nodes in does not matter); the children a node's rays enter are taken
# nearest first (by the least entry distance over their rays), the others pushed with
# their rays and those rays' entry distances, and a popped node goes on only with the
# rays whose nearest hit is not nearer than where they enter it.
_CLOSEST_PACKET = """
#if defined(__CUDA_ARCH__)
return MISS;
#else
PACKET_RAYS
HIT_ROW
const int none = NO_CHILD;
vPf best = tmax;
vPi best_k = -1;
vPf best_u = 0.0f, best_v = 0.0f;
int stack[STACK];
unsigned stack_m[STACK];
vPf stack_t[STACK];
int sp = 0;
if (live != 0) { stack[0] = 0; stack_m[0] = live; stack_t[0] = 0.0f; sp = 1; }
while (sp > 0) {
    --sp;
    int cur = stack[sp];
    unsigned m = stack_m[sp] & (unsigned)__builtin_reduce_or((stack_t[sp] <= best) & lane_bit);
    if (m == 0) continue;
    while (cur >= 0) {
        const float* b = nb + NODE_FLOATS * cur;
        const int* c = (const int*)(b + CHILD_LANES);
        int hit_c[4];
        unsigned hit_m[4];
        float hit_key[4];
        vPf hit_t[4];
        int hits = 0;
        for (int j = 0; j < 4; ++j) {
            if (c[j] == none) continue;
PACKET_BOX
            const vPi in = (near_t <= far_t) & (near_t <= best) & (((vPi)(int)m & lane_bit) != 0);
            const unsigned em = (unsigned)__builtin_reduce_or(in & lane_bit);
            if (em == 0) continue;
            const float key = __builtin_reduce_min(in ? near_t : (vPf)INFINITY);
            int q = hits++;
            while (q > 0 && hit_key[q - 1] > key) {
                hit_key[q] = hit_key[q - 1]; hit_c[q] = hit_c[q - 1]; hit_m[q] = hit_m[q - 1]; hit_t[q] = hit_t[q - 1];
                --q;
            }
            hit_key[q] = key; hit_c[q] = c[j]; hit_m[q] = em; hit_t[q] = near_t;
        }
        if (hits == 0) { cur = none; break; }
        for (int q = hits - 1; q >= 1; --q) { stack[sp] = hit_c[q]; stack_m[sp] = hit_m[q]; stack_t[sp] = hit_t[q]; ++sp; }
        cur = hit_c[0];
        m = hit_m[0];
    }
    if (cur == none) continue;
    const int leaf = -cur - 1;
    const int leaf_end = lv[2 * leaf + 1];
    const vPi in_play = ((vPi)(int)m & lane_bit) != 0;
    for (int g = lv[2 * leaf]; g < leaf_end; ++g) {
PACKET_CORNERS
WATERTIGHT_LANES
        keep &= in_play & (tt >= 0.0f) & ((tt < best) | ((tt == best) & (g < best_k)));
        if (!__builtin_reduce_or(keep)) continue;
        best = keep ? tt : best;
        best_k = keep ? (vPi)g : best_k;
        best_u = keep ? U * rcp : best_u;
        best_v = keep ? V * rcp : best_v;
    }
}
wp::mat_t<PACKET, 8, float> out;
for (int j = 0; j < PACKET; ++j) {
    for (int e = 0; e < 8; ++e) out.data[j][e] = -1.0f;
    if (best_k[j] < 0) continue;
    const wp::vec_t<8, float> r = wh_hit_row(best_k[j], best[j], best_u[j], best_v[j]);
    for (int e = 0; e < 8; ++e) out.data[j][e] = r[e];
}
return out;
#endif
"""


def _packet_query(body: str, miss: str) -> str:
    """A packet query's C++: ``body`` with the shared pieces and the constants filled in."""
    return (
        body.replace("PACKET_RAYS", _PACKET_RAYS)
        .replace("HIT_ROW", _HIT_ROW_CPP)
        .replace("SLOT_K", slot_lane_cpp("k"))
        .replace("MISS", miss)
        .replace("PACKET_BOX", _PACKET_BOX)
        .replace("PACKET_CORNERS", _PACKET_CORNERS)
        .replace("SLOT_G", slot_lane_cpp("g"))
        .replace("WIDEN", _WIDEN)
        .replace("SLAB_SPAN", _lanes(_SLAB_SPAN, "vPf", "vPi", "PACKET"))
        .replace("WATERTIGHT_LANES", _lanes(_WATERTIGHT_LANES, "vPf", "vPi", "PACKET"))
        .replace("PACKET", str(PACKET))
        .replace("STACK", str(STACK_SIZE))
        .replace("NODE_FLOATS", str(NODE_FLOATS))
        .replace("CHILD_LANES", str(CHILD_LANES))
        .replace("NO_CHILD", NO_CHILD_C)
    )


@wp.func_native(_packet_query(_ANY_PACKET, "0"))
def _any_packet(
    node_data: wp.array(dtype=wp.float32),
    leaves: wp.array(dtype=wp.int32),
    corners: wp.array(dtype=wp.float32),
    nodes: int,
    o: _packet_points,
    d: _packet_points,
    max_t: _packet_floats,
) -> int: ...


#: A packet's closest hits: row j ray j's, as ``_closest`` gives one.
_packet_hits = wp.types.matrix(shape=(PACKET, 8), dtype=wp.float32)


@wp.func_native(_packet_query(_CLOSEST_PACKET, f"wp::mat_t<{PACKET}, 8, float>(-1.0f)"))
def _closest_packet(
    node_data: wp.array(dtype=wp.float32),
    leaves: wp.array(dtype=wp.int32),
    corners: wp.array(dtype=wp.float32),
    faces: wp.array(dtype=wp.int32),
    nodes: int,
    o: _packet_points,
    d: _packet_points,
    max_t: _packet_floats,
) -> _packet_hits: ...


@wp.struct
class WideHit:
    """A closest hit as ``wp.mesh_query_ray`` gives it: ``result``, ``face``, ``t``,
    barycentrics ``u``, ``v`` (Warp's convention) and the unit face ``normal``."""

    result: bool
    face: int
    t: float
    u: float
    v: float
    normal: wp.vec3


@wp.func
def hit_from_row(r: _hit8) -> WideHit:
    """A ``WideHit`` from a query's (face, t, u, v, normal x, y, z, found) row: ``_closest``'s
    answer, or a row of ``wide_closest_packet``'s."""
    h = WideHit()
    h.result = r[7] > 0.0
    h.face = int(r[0])
    h.t = r[1]
    h.u = r[2]
    h.v = r[3]
    h.normal = wp.vec3(r[4], r[5], r[6])
    return h


@wp.func
def wide_closest(bvh: WideBVHGPU, o: wp.vec3, d: wp.vec3, max_t: float) -> WideHit:
    """The nearest hit of the ray ``o + t d``, 0 <= t < ``max_t`` (``wp.mesh_query_ray``)."""
    return hit_from_row(_closest(bvh.node_data, bvh.leaves, bvh.corners, bvh.faces, bvh.nodes, o, d, max_t))


@wp.func
def wide_any_hit(bvh: WideBVHGPU, o: wp.vec3, d: wp.vec3, max_t: float) -> bool:
    """Whether the ray ``o + t d`` hits any triangle at 0 <= t < ``max_t``
    (``wp.mesh_query_ray_anyhit``)."""
    return _any(bvh.node_data, bvh.leaves, bvh.corners, bvh.faces, bvh.nodes, o, d, max_t)


@wp.func
def wide_any_hit_packet(bvh: WideBVHGPU, o: _packet_points, d: _packet_points, max_t: _packet_floats) -> int:
    """``wide_any_hit`` for ``PACKET`` rays at once (row j: ray ``o[j] + t d[j]``, ``0 <= t <
    max_t[j]``; a ray of ``max_t <= 0`` is none): bit j set where ray j hits, the same
    answer as ``wide_any_hit`` ray by ray.  Rays that leave near one another (a row of
    pixels toward one light) share the nodes they visit, about 2.4x faster than one at a
    time on the staircase's shadow rays."""
    return _any_packet(bvh.node_data, bvh.leaves, bvh.corners, bvh.nodes, o, d, max_t)


@wp.func
def wide_closest_packet(bvh: WideBVHGPU, o: _packet_points, d: _packet_points, max_t: _packet_floats) -> _packet_hits:
    """``wide_closest`` for ``PACKET`` rays at once (rays as ``wide_any_hit_packet``'s):
    row j ray j's hit (``hit_from_row`` reads it), the same answer as ``wide_closest`` ray by
    ray, bit for bit (both take the nearest triangle, at equal distances the first in the
    tree's leaf order)."""
    return _closest_packet(bvh.node_data, bvh.leaves, bvh.corners, bvh.faces, bvh.nodes, o, d, max_t)


@wp.func
def _listed_points(a: wp.array(dtype=wp.vec3), first: int) -> _packet_points:
    """Rows ``first`` .. ``first + PACKET - 1`` of ``a`` (zero past its end)."""
    out = _packet_points()
    for j in range(PACKET):
        if first + j < a.shape[0]:
            out[j] = a[first + j]
    return out


@wp.func
def _listed_lengths(a: wp.array(dtype=float), first: int) -> _packet_floats:
    """Entries ``first`` .. ``first + PACKET - 1`` of ``a`` (0, no ray, past its end)."""
    out = _packet_floats()
    for j in range(PACKET):
        if first + j < a.shape[0]:
            out[j] = a[first + j]
    return out


@wp.func
def _store_hit(hits: wp.array(dtype=wp.vec4), normals: wp.array(dtype=wp.vec3), i: int, h: WideHit):
    """``hits[i]`` (face, t, u, v) of hit ``h``, (-1, 0, 0, 0) for none; ``normals[i]`` its
    face normal where found."""
    hits[i] = wp.vec4(-1.0, 0.0, 0.0, 0.0)
    if h.result:
        hits[i] = wp.vec4(float(h.face), h.t, h.u, h.v)
        normals[i] = h.normal


@wp.kernel
def closest_hits(
    bvh: WideBVHGPU,
    o: wp.array(dtype=wp.vec3),
    d: wp.array(dtype=wp.vec3),
    max_t: wp.array(dtype=float),
    hits: wp.array(dtype=wp.vec4),
    normals: wp.array(dtype=wp.vec3),
):
    """``packet_closest_hits`` one ray a thread (``wide_closest``), the same outputs.
    Launch ``len`` threads."""
    i = wp.tid()
    _store_hit(hits, normals, i, wide_closest(bvh, o[i], d[i], max_t[i]))


@wp.kernel
def packet_closest_hits(
    bvh: WideBVHGPU,
    o: wp.array(dtype=wp.vec3),
    d: wp.array(dtype=wp.vec3),
    max_t: wp.array(dtype=float),
    hits: wp.array(dtype=wp.vec4),
    normals: wp.array(dtype=wp.vec3),
):
    """The closest hits of a list of rays, rays ``PACKET * tid`` on as one packet
    (``wide_closest_packet``): ``hits[i]`` (face, t, u, v) of ray i's hit, (-1, 0, 0, 0)
    for none, ``normals[i]`` its face normal.  Launch ``ceil(len / PACKET)`` threads."""
    first = wp.tid() * PACKET
    po = _listed_points(o, first)
    pd = _listed_points(d, first)
    pt = _listed_lengths(max_t, first)
    found = wide_closest_packet(bvh, po, pd, pt)
    for j in range(PACKET):
        if first + j < o.shape[0]:
            _store_hit(hits, normals, first + j, hit_from_row(found[j]))


@wp.kernel
def packet_any_hits(
    bvh: WideBVHGPU,
    o: wp.array(dtype=wp.vec3),
    d: wp.array(dtype=wp.vec3),
    max_t: wp.array(dtype=float),
    blocked: wp.array(dtype=wp.int32),
):
    """The any-hits of a list of rays, rays ``PACKET * tid`` on as one packet
    (``wide_any_hit_packet``; the last packet's spare lanes carry no ray): ``blocked[i]``
    1 where ray i hits, else 0.  Launch ``ceil(len / PACKET)`` threads."""
    first = wp.tid() * PACKET
    po = _listed_points(o, first)
    pd = _listed_points(d, first)
    pt = _listed_lengths(max_t, first)
    bits = wide_any_hit_packet(bvh, po, pd, pt)
    for j in range(PACKET):
        if first + j < o.shape[0]:
            blocked[first + j] = (bits >> j) & 1


def grouped_leaves(order: np.ndarray, spans: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The leaves laid out in groups of four slots: ``order`` (the faces in leaf order) and
    ``spans`` (first, end of each leaf in it) -> the faces of the slots and each leaf's
    (first, end) among them.  Each leaf starts a group and fills whole groups, its last
    group's spare slots repeating that group's first face; the leaves keep their order
    in ``order`` (so a triangle's slot orders the triangles as its place in ``order`` did:
    the tie rule's leaf order is unchanged)."""
    firsts = spans[:, 0].astype(np.int64)
    counts = (spans[:, 1] - spans[:, 0]).astype(np.int64)
    slots = (counts + 3) // 4 * 4
    by_place = np.argsort(firsts, kind="stable")
    starts = np.empty_like(slots)
    starts[by_place] = np.concatenate(([0], np.cumsum(slots[by_place])[:-1]))
    leaf = np.repeat(by_place, slots[by_place])  # each slot's leaf, slot by slot
    i = np.arange(int(slots.sum())) - starts[leaf]
    source = firsts[leaf] + np.where(i < counts[leaf], i, i // 4 * 4)
    grouped = np.stack([starts, starts + counts], axis=1).astype(np.int32)
    return np.ascontiguousarray(order[source], dtype=np.int32), grouped


def use_wide_bvh(setting: bool | None, device: wp.context.Device) -> bool:
    """Whether passes on ``device`` query the 4-wide copies for the setting
    ``wide_bvh`` (``RenderSettings``/``TraceSettings``): None means on the CPU, not on
    CUDA; True on CUDA raises ``RenderSettingsError`` (the copies are CPU only)."""
    wide = device.is_cpu if setting is None else bool(setting)
    if wide and not device.is_cpu:
        raise RenderSettingsError(f"the 4-wide BVH copies are CPU only, not for {device.alias}")
    return wide


class WideBVH:
    """The 4-wide BVH over one CPU ``wp.Mesh``'s triangles (module docstring); ``gpu`` for kernels."""

    def __init__(
        self,
        mesh: wp.Mesh | None,
        triangles: int,
        device: wp.context.Device | str | None = None,
        max_leaf: int = MAX_LEAF,
        max_depth: int = MAX_DEPTH,
    ) -> None:
        """Build the tree over ``mesh``'s ``triangles`` faces (its points and indices; None or
        0: an empty tree, its arrays on ``device``, default the mesh's or the CPU), leaves
        of at most ``max_leaf`` triangles except at depth ``max_depth`` (``wide_bvh_build``)."""
        self.mesh = mesh
        dev = wp.get_device(device) if device is not None else mesh.device if mesh is not None else wp.get_device("cpu")
        g = WideBVHGPU()
        g.nodes = 0
        if mesh is None or triangles == 0:
            g.node_data = wp.zeros(1, dtype=wp.float32, device=dev)
            g.leaves = wp.zeros(1, dtype=wp.int32, device=dev)
            g.corners = wp.zeros(1, dtype=wp.float32, device=dev)
            g.faces = wp.zeros(1, dtype=wp.int32, device=dev)
            self.gpu = g
            return
        if not dev.is_cpu:
            raise ValueError("WideBVH is the CPU tracer's; on CUDA the tracer uses Warp's own queries")
        if max_leaf < 1 or not 0 <= max_depth <= MAX_DEPTH:
            raise ValueError(f"max_leaf {max_leaf} must be at least 1 and max_depth {max_depth} in 0..{MAX_DEPTH}")
        # A binary tree of at most T leaves has fewer than 2 T nodes; the 4-wide one has fewer
        # nodes than the binary one has inner nodes, and as many leaves (both at most T).
        g.faces = wp.empty(triangles, dtype=wp.int32, device=dev)
        node_box = wp.empty(12 * triangles, dtype=wp.float32, device=dev)
        node_a = wp.empty(2 * triangles, dtype=wp.int32, device=dev)
        node_b = wp.empty(2 * triangles, dtype=wp.int32, device=dev)
        scratch = wp.empty(6 * triangles, dtype=wp.float32, device=dev)
        build_inputs = [
            mesh.points,
            mesh.indices,
            triangles,
            max_leaf,
            max_depth,
            scratch,
            g.faces,
            node_box,
            node_a,
            node_b,
        ]
        wp.launch(build_kernel, 1, build_inputs, device=dev)
        del scratch
        children = wp.empty(WIDTH * triangles, dtype=wp.int32, device=dev)
        leaves = wp.empty(2 * triangles, dtype=wp.int32, device=dev)
        counts = wp.zeros(2, dtype=wp.int32, device=dev)
        wp.launch(collapse_kernel, 1, [node_box, node_a, node_b, children, leaves, counts], device=dev)
        del node_box, node_a, node_b
        nodes, leaf_count = (int(v) for v in counts.numpy())
        node_data = np.zeros((nodes, NODE_FLOATS), np.float32)  # the boxes come from refit
        node_data.view(np.int32)[:, CHILD_LANES : CHILD_LANES + WIDTH] = children.numpy()[: WIDTH * nodes].reshape(
            -1, WIDTH
        )
        g.node_data = wp.array(node_data.ravel(), dtype=wp.float32, device=dev)
        faces, spans = grouped_leaves(g.faces.numpy(), leaves.numpy()[: 2 * leaf_count].reshape(-1, 2))
        del children, leaves
        g.faces = wp.array(faces, dtype=wp.int32, device=dev)
        g.leaves = wp.array(spans.ravel(), dtype=wp.int32, device=dev)
        g.corners = wp.empty(9 * len(faces), dtype=wp.float32, device=dev)
        g.nodes = nodes
        self.gpu = g
        # the refit's flags: a byte a slot (its corners moved), a byte a node (a box changed)
        self._dirty = (wp.empty(len(faces), dtype=wp.uint8, device=dev), wp.empty(nodes, dtype=wp.uint8, device=dev))
        self._every = wp.zeros(1, dtype=wp.uint8, device=dev)  # the moved flags a whole refit does not read
        self.refit()

    @property
    def node_count(self) -> int:
        """4-wide nodes (0 for an empty tree)."""
        return int(self.gpu.nodes)

    def refit(self, moved: np.ndarray | None = None) -> None:
        """Copy the mesh's corners again and compute the boxes from them (after its points
        moved; the tree's shape stays).  ``moved``: a bool per point of the mesh's points
        array, True where a point moved since the last refit (e.g. ``DeviceScene.update``'s);
        then only the triangles touching one, their leaves and the nodes above them are
        done again, with the same result as the whole refit.  None: everything."""
        if self.gpu.nodes == 0:
            return
        g, dev = self.gpu, self.mesh.device
        mask = self._every
        if moved is not None:
            moved = np.ascontiguousarray(moved, dtype=bool)
            if moved.shape != (self.mesh.points.shape[0],):
                raise ValueError(f"moved has shape {moved.shape}, expected ({self.mesh.points.shape[0]},): one a point")
            mask = wp.array(moved.view(np.uint8), dtype=wp.uint8, device=dev, copy=False)
        inputs = [self.mesh.points, self.mesh.indices, g.faces, mask, int(moved is None), g.corners]
        wp.launch(refit_kernel, 1, [*inputs, g.node_data, g.leaves, g.nodes, *self._dirty], device=dev)
