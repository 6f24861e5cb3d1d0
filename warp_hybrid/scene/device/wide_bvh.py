"""A 4-wide copy of a ``wp.Mesh``'s BVH for the CPU tracer: the same boxes, four children
to a node tested at once, and each leaf's triangles stored in order beside it.

Warp's CPU ray queries walk a binary tree: each step loads two children and tests two
boxes, and each leaf triangle is reached through two index lookups (the leaf's
primitive list, then the mesh's vertex indices).  ``WideBVH`` collapses that same tree
(Warp's SAH build, untouched) into nodes of up to four children -- a binary node's
children, then the children of its largest child, until there are four or only leaves
-- whose boxes are stored as six 4-lane rows (low and high x, y, z), so one node is
one 4-wide slab test (clang vector extensions, SSE on any x86-64), and copies each
leaf's triangle corners into one array in leaf order.  Leaves keep Warp's triangles and
its watertight triangle test (``intersect_ray_tri_woop``), the ray's part of it once per
ray and the triangle's part for four of a leaf's triangles at once, each lane Warp's
arithmetic operation for operation, so the answers are Warp's:
the same face, distance and barycentrics (``tests/scene/device/test_wide_bvh.py``); a hit at
exactly the same distance as another may be found in the other order.

``wide_closest`` is ``wp.mesh_query_ray`` (nearest hit, children visited near first,
a child skipped once its entry distance is past the nearest hit); ``wide_any_hit`` is
``wp.mesh_query_ray_anyhit``.  The slab test widens its far distance by
``1 + 2 gamma(3)`` (pbrt-v4's robust ray-box test), so rounding never culls a box the
ray touches, and an axis the ray does not move along tests the origin against the slab
(as Warp's robust test does), so rays along a box's face still enter it.  Measured on
the staircase (262k triangles, one thread, 640x480 G-buffer points): a mirror ray's
closest hit 1242 ns with Warp's query, 498 ns with this one; a shadow ray's any-hit
913 ns and 315 ns (README, "4-wide BVH copies").

CPU only: the tracer's CUDA variant keeps Warp's own queries (``TraceVariant.wide_bvh``),
and the native code compiles to a stub under ``__CUDA_ARCH__``.  The scene's own copy is
``DeviceScene.wide_bvh`` (built on first use); the tracer's shadow BVHs have theirs
(``trace/occluders.py``); the ray-cast primaries (``--primary raycast``, the fovea
sampler's window samples) query the scene's copy too.  ``use_wide_bvh`` is the one rule
for whether a pass queries the copies.  After the mesh is
refitted (``wp.Mesh.refit``, animated points) ``refit`` copies the new boxes and
corners; the tree's shape is Warp's and does not change on a refit.
"""

from __future__ import annotations

import warp as wp

from ...errors import RenderSettingsError

#: Children per node.
WIDTH = 4
#: The traversal stack: up to three entries pushed a level (the nearest child is taken
#: at once), so 96 entries hold 32 levels of the 4-wide tree (64 of Warp's binary one,
#: whose own query stack holds 32).
STACK_SIZE = 96
#: ``children`` entry of an unused child slot.
NO_CHILD = wp.constant(-(2**31))


@wp.struct
class WideBVHGPU:
    """The kernel-side tree.  ``boxes``: 24 floats a node (low x, y, z then high x, y, z,
    4 lanes each); ``children``: 4 a node (>= 0 a node, ``-(leaf + 1)`` a leaf,
    ``NO_CHILD`` unused); ``leaves``: 2 a leaf (first and end triangle in leaf order);
    ``corners``: 9 floats a triangle in leaf order; ``faces``: the mesh's face of each;
    ``nodes``: 0 for an empty mesh (every query misses)."""

    boxes: wp.array(dtype=wp.float32)
    children: wp.array(dtype=wp.int32)
    leaves: wp.array(dtype=wp.int32)
    corners: wp.array(dtype=wp.float32)
    faces: wp.array(dtype=wp.int32)
    nodes: int


@wp.func_native(
    """
#if !defined(__CUDA_ARCH__)
const wp::Mesh mesh = wp::mesh_get(id);
const wp::BVH& bvh = mesh.bvh;
const int root = *bvh.root;
int wide = 1, leaf_count = 0;
int work_node[4096], work_slot[4096], top = 0;
auto is_leaf = [&](int k) { return bvh.node_lowers[k].b != 0; };
auto area = [&](int k) {
    const wp::BVHPackedNodeHalf& lo = bvh.node_lowers[k];
    const wp::BVHPackedNodeHalf& hi = bvh.node_uppers[k];
    const float x = hi.x - lo.x, y = hi.y - lo.y, z = hi.z - lo.z;
    return x * y + y * z + z * x;
};
work_node[0] = root; work_slot[0] = 0; top = 1;
while (top > 0) {
    --top;
    const int node = work_node[top], slot = work_slot[top];
    int kids[4], n = 0;
    if (is_leaf(node)) {
        kids[n++] = node;
    } else {
        kids[n++] = (int)bvh.node_lowers[node].i;
        kids[n++] = (int)bvh.node_uppers[node].i;
    }
    while (n < 4) {
        int big = -1;
        for (int j = 0; j < n; ++j)
            if (!is_leaf(kids[j]) && (big < 0 || area(kids[j]) > area(kids[big]))) big = j;
        if (big < 0) break;
        const int split = kids[big];
        kids[big] = (int)bvh.node_lowers[split].i;
        kids[n++] = (int)bvh.node_uppers[split].i;
    }
    for (int j = 0; j < 4; ++j) {
        const int at = 4 * slot + j;
        if (j >= n) { children.data[at] = (int)0x80000000; source.data[at] = -1; continue; }
        source.data[at] = kids[j];
        if (is_leaf(kids[j])) {
            leaves.data[2 * leaf_count] = (int)bvh.node_lowers[kids[j]].i;
            leaves.data[2 * leaf_count + 1] = (int)bvh.node_uppers[kids[j]].i;
            children.data[at] = -(leaf_count + 1);
            ++leaf_count;
        } else {
            if (top >= 4096) { counts.data[0] = -1; return; }
            children.data[at] = wide;
            work_node[top] = kids[j]; work_slot[top] = wide; ++top;
            ++wide;
        }
    }
}
counts.data[0] = wide;
counts.data[1] = leaf_count;
#endif
"""
)
def _collapse(
    id: wp.uint64,
    children: wp.array(dtype=wp.int32),
    source: wp.array(dtype=wp.int32),
    leaves: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
): ...


@wp.kernel(enable_backward=False)
def collapse_kernel(
    id: wp.uint64,
    children: wp.array(dtype=wp.int32),
    source: wp.array(dtype=wp.int32),
    leaves: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
):
    """Collapse the mesh's binary BVH into 4-wide nodes (one thread): ``children`` and
    ``leaves`` as ``WideBVHGPU`` holds them, ``source`` the binary node behind each child
    slot (-1 unused), ``counts`` (nodes, leaves), nodes -1 when the tree is too deep."""
    _collapse(id, children, source, leaves, counts)


@wp.func_native(
    """
#if !defined(__CUDA_ARCH__)
const wp::BVH& bvh = wp::mesh_get(id).bvh;
float* b = boxes.data + 24 * node;
for (int j = 0; j < 4; ++j) {
    const int k = source.data[4 * node + j];
    if (k < 0) {
        b[j] = b[4 + j] = b[8 + j] = __builtin_inff();
        b[12 + j] = b[16 + j] = b[20 + j] = -__builtin_inff();
        continue;
    }
    const wp::BVHPackedNodeHalf& lo = bvh.node_lowers[k];
    const wp::BVHPackedNodeHalf& hi = bvh.node_uppers[k];
    b[j] = lo.x; b[4 + j] = lo.y; b[8 + j] = lo.z;
    b[12 + j] = hi.x; b[16 + j] = hi.y; b[20 + j] = hi.z;
}
#endif
"""
)
def _node_boxes(id: wp.uint64, source: wp.array(dtype=wp.int32), boxes: wp.array(dtype=wp.float32), node: int): ...


@wp.kernel(enable_backward=False)
def node_boxes_kernel(id: wp.uint64, source: wp.array(dtype=wp.int32), boxes: wp.array(dtype=wp.float32)):
    """Per wide node: its children's boxes from the mesh's BVH (empty slots hold an
    inverted box no ray enters)."""
    _node_boxes(id, source, boxes, wp.tid())


@wp.func_native(
    """
#if !defined(__CUDA_ARCH__)
const wp::Mesh mesh = wp::mesh_get(id);
const int face = mesh.bvh.primitive_indices[k];
faces.data[k] = face;
for (int c = 0; c < 3; ++c) {
    const wp::vec3 p = mesh.points[mesh.indices[3 * face + c]];
    corners.data[9 * k + 3 * c] = p[0];
    corners.data[9 * k + 3 * c + 1] = p[1];
    corners.data[9 * k + 3 * c + 2] = p[2];
}
#endif
"""
)
def _leaf_corners(id: wp.uint64, corners: wp.array(dtype=wp.float32), faces: wp.array(dtype=wp.int32), k: int): ...


@wp.kernel(enable_backward=False)
def leaf_corners_kernel(id: wp.uint64, corners: wp.array(dtype=wp.float32), faces: wp.array(dtype=wp.int32)):
    """Per triangle in leaf order: its face and its three corners, copied from the mesh."""
    _leaf_corners(id, corners, faces, wp.tid())


# The traversal shared by both queries: ``ANY`` (0 or 1) picks the any-hit query.
_TRAVERSE = """
#if defined(__CUDA_ARCH__)
return MISS;
#else
typedef float v4f __attribute__((ext_vector_type(4)));
typedef int v4i __attribute__((ext_vector_type(4)));
if (nodes <= 0) return MISS;
const float* nb = boxes.data;
const int* nc = children.data;
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
const float widen = 1.0f + 2.0f * (3.0f * 5.96046448e-08f) / (1.0f - 3.0f * 5.96046448e-08f);
// Warp's watertight triangle test (wp::intersect_ray_tri_woop), its ray part once per ray
// (the axis permutation and shear) and its triangle part for four triangles of a leaf at a
// time, each lane the same operations as Warp's scalar code, so each lane's answer is Warp's.
int kz = wp::max_dim(d);
int kx = kz + 1;
if (kx == 3) kx = 0;
int ky = kx + 1;
if (ky == 3) ky = 0;
if (d[kz] < 0.0f) { const int tmp = kx; kx = ky; ky = tmp; }
const float Sx = d[kx] / d[kz];
const float Sy = d[ky] / d[kz];
const float Sz = 1.0f / d[kz];
const int none = (int)0x80000000;
float best = max_t;
int best_k = -1;
float best_u = 0.0f, best_v = 0.0f;
int stack[STACK];
float stack_t[STACK];
int sp = 0;
int cur = 0;
while (true) {
    while (cur >= 0) {
        const float* b = nb + 24 * cur;
        v4f t0x = (*(const v4f*)(b + 0) - ox) * ix, t1x = (*(const v4f*)(b + 12) - ox) * ix;
        v4f t0y = (*(const v4f*)(b + 4) - oy) * iy, t1y = (*(const v4f*)(b + 16) - oy) * iy;
        v4f t0z = (*(const v4f*)(b + 8) - oz) * iz, t1z = (*(const v4f*)(b + 20) - oz) * iz;
        if (flat_x) flat_slab(t0x, t1x, b + 0, b + 12, o[0]);
        if (flat_y) flat_slab(t0y, t1y, b + 4, b + 16, o[1]);
        if (flat_z) flat_slab(t0z, t1z, b + 8, b + 20, o[2]);
        const v4f near_t = __builtin_elementwise_max(
            __builtin_elementwise_max(__builtin_elementwise_min(t0x, t1x), __builtin_elementwise_min(t0y, t1y)),
            __builtin_elementwise_max(__builtin_elementwise_min(t0z, t1z), (v4f)0.0f));
        const v4f far_t = __builtin_elementwise_min(
            __builtin_elementwise_min(__builtin_elementwise_max(t0x, t1x), __builtin_elementwise_max(t0y, t1y)),
            __builtin_elementwise_max(t0z, t1z)) * widen;
        const int* c = nc + 4 * cur;
        int hit_c[4];
        float hit_t[4];
        int hits = 0;
        for (int j = 0; j < 4; ++j) {
            if (c[j] != none && near_t[j] <= far_t[j] && near_t[j] <= best) {
                int q = hits++;
                while (q > 0 && hit_t[q - 1] > near_t[j]) { hit_t[q] = hit_t[q - 1]; hit_c[q] = hit_c[q - 1]; --q; }
                hit_t[q] = near_t[j];
                hit_c[q] = c[j];
            }
        }
        if (hits == 0) { cur = none; break; }
        if (sp + hits - 1 > STACK) { cur = none; sp = 0; break; }
        for (int q = hits - 1; q >= 1; --q) { stack[sp] = hit_c[q]; stack_t[sp] = hit_t[q]; ++sp; }
        cur = hit_c[0];
    }
    if (cur != none) {
        const int leaf = -cur - 1;
        const int leaf_end = lv[2 * leaf + 1];
        for (int g = lv[2 * leaf]; g < leaf_end; g += 4) {
            const int n = leaf_end - g < 4 ? leaf_end - g : 4;
            v4f Ax, Ay, Az, Bx, By, Bz, Cx, Cy, Cz;
            for (int j = 0; j < 4; ++j) {
                const float* t = tv + 9 * (g + (j < n ? j : 0));  // a spare lane repeats the first
                Ax[j] = t[kx] - o[kx]; Ay[j] = t[ky] - o[ky]; Az[j] = t[kz] - o[kz];
                Bx[j] = t[3 + kx] - o[kx]; By[j] = t[3 + ky] - o[ky]; Bz[j] = t[3 + kz] - o[kz];
                Cx[j] = t[6 + kx] - o[kx]; Cy[j] = t[6 + ky] - o[ky]; Cz[j] = t[6 + kz] - o[kz];
            }
            const v4f ax = Ax - Sx * Az, ay = Ay - Sy * Az;
            const v4f bx = Bx - Sx * Bz, by = By - Sy * Bz;
            const v4f cx = Cx - Sx * Cz, cy = Cy - Sy * Cz;
            auto diff_product = [](v4f a, v4f b, v4f c, v4f e) {
                const v4f ce = c * e;
                return __builtin_elementwise_fma(a, b, -ce) + __builtin_elementwise_fma(-c, e, ce);
            };
            v4f U = diff_product(cx, by, cy, bx);
            v4f V = diff_product(ax, cy, ay, cx);
            v4f W = diff_product(bx, ay, by, ax);
            // Warp's fallback where an edge function is exactly zero: the products in double
            const v4i zero = (U == 0.0f) | (V == 0.0f) | (W == 0.0f);
            if (__builtin_reduce_or(zero)) {
                for (int j = 0; j < n; ++j) {
                    if (zero[j]) {
                        U[j] = (float)((double)cx[j] * (double)by[j] - (double)cy[j] * (double)bx[j]);
                        V[j] = (float)((double)ax[j] * (double)cy[j] - (double)ay[j] * (double)cx[j]);
                        W[j] = (float)((double)bx[j] * (double)ay[j] - (double)by[j] * (double)ax[j]);
                    }
                }
            }
            const v4i outside = ((U < 0.0f) | (V < 0.0f) | (W < 0.0f)) & ((U > 0.0f) | (V > 0.0f) | (W > 0.0f));
            const v4f det = U + V + W;
            const v4f az = Sz * Az, bz = Sz * Bz, cz = Sz * Cz;
            const v4f T = U * az + V * bz + W * cz;
            // wp::xorf(T, wp::sign_mask(det)) < 0: T carrying det's sign bit, compared as a float
            const v4i det_sign = __builtin_bit_cast(v4i, det) & (int)0x80000000;
            const v4i behind = __builtin_bit_cast(v4f, __builtin_bit_cast(v4i, T) ^ det_sign) < 0.0f;
            v4i keep = ~outside & (det != 0.0f) & ~behind;
            if (!__builtin_reduce_or(keep)) continue;
            const v4f rcp = 1.0f / det;
            const v4f tt = T * rcp;
            keep &= (tt < best) & (tt >= 0.0f);
            if (!__builtin_reduce_or(keep)) continue;
            for (int j = 0; j < n; ++j) {  // in leaf order, as Warp's loop
                if (keep[j] && tt[j] < best) {
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
""".replace("STACK", str(STACK_SIZE))

#: (face, t, u, v, normal x, y, z, 1) of a hit; all -1 for none.
_hit8 = wp.types.vector(length=8, dtype=wp.float32)

_CLOSEST = (
    _TRAVERSE.replace("MISS", "wp::vec_t<8, float>(-1.0f)")
    .replace("if (ANY) return HIT;", "")
    .replace(
        "FOUND",
        "[&] { const float* t = tv + 9 * best_k; const wp::vec3 a(t[0], t[1], t[2]);"
        " const wp::vec3 n = wp::normalize(wp::cross(wp::vec3(t[3], t[4], t[5]) - a, wp::vec3(t[6], t[7], t[8]) - a));"
        " wp::vec_t<8, float> r; r[0] = (float)faces.data[best_k];"
        " r[1] = best; r[2] = best_u; r[3] = best_v; r[4] = n[0]; r[5] = n[1]; r[6] = n[2]; r[7] = 1.0f; return r; }()",
    )
)

_ANY = _TRAVERSE.replace("MISS", "false").replace("if (ANY) return HIT;", "return true;").replace("FOUND", "true")


@wp.func_native(_CLOSEST)
def _closest(
    boxes: wp.array(dtype=wp.float32),
    children: wp.array(dtype=wp.int32),
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
    boxes: wp.array(dtype=wp.float32),
    children: wp.array(dtype=wp.int32),
    leaves: wp.array(dtype=wp.int32),
    corners: wp.array(dtype=wp.float32),
    faces: wp.array(dtype=wp.int32),
    nodes: int,
    o: wp.vec3,
    d: wp.vec3,
    max_t: float,
) -> bool: ...


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
def wide_closest(bvh: WideBVHGPU, o: wp.vec3, d: wp.vec3, max_t: float) -> WideHit:
    """The nearest hit of the ray ``o + t d``, 0 <= t < ``max_t`` (``wp.mesh_query_ray``)."""
    r = _closest(bvh.boxes, bvh.children, bvh.leaves, bvh.corners, bvh.faces, bvh.nodes, o, d, max_t)
    h = WideHit()
    h.result = r[7] > 0.0
    h.face = int(r[0])
    h.t = r[1]
    h.u = r[2]
    h.v = r[3]
    h.normal = wp.vec3(r[4], r[5], r[6])
    return h


@wp.func
def wide_any_hit(bvh: WideBVHGPU, o: wp.vec3, d: wp.vec3, max_t: float) -> bool:
    """Whether the ray ``o + t d`` hits any triangle at 0 <= t < ``max_t``
    (``wp.mesh_query_ray_anyhit``)."""
    return _any(bvh.boxes, bvh.children, bvh.leaves, bvh.corners, bvh.faces, bvh.nodes, o, d, max_t)


def use_wide_bvh(setting: bool | None, device: wp.context.Device) -> bool:
    """Whether passes on ``device`` query the 4-wide copies for the setting
    ``wide_bvh`` (``RenderSettings``/``TraceSettings``): None means on the CPU, not on
    CUDA; True on CUDA raises ``RenderSettingsError`` (the copies are CPU only)."""
    wide = device.is_cpu if setting is None else bool(setting)
    if wide and not device.is_cpu:
        raise RenderSettingsError(f"the 4-wide BVH copies are CPU only, not for {device.alias}")
    return wide


class WideBVH:
    """The 4-wide copy of one CPU ``wp.Mesh``'s BVH (module docstring); ``gpu`` for kernels."""

    def __init__(self, mesh: wp.Mesh | None, triangles: int, device: wp.context.Device | str | None = None) -> None:
        """Collapse ``mesh``'s BVH (``triangles`` faces; None or 0: an empty tree, its
        arrays on ``device``, default the mesh's or the CPU)."""
        self.mesh = mesh
        dev = wp.get_device(device) if device is not None else mesh.device if mesh is not None else wp.get_device("cpu")
        g = WideBVHGPU()
        g.nodes = 0
        if mesh is None or triangles == 0:
            self._source = wp.zeros(1, dtype=wp.int32, device=dev)
            g.boxes = wp.zeros(1, dtype=wp.float32, device=dev)
            g.children = wp.zeros(1, dtype=wp.int32, device=dev)
            g.leaves = wp.zeros(1, dtype=wp.int32, device=dev)
            g.corners = wp.zeros(1, dtype=wp.float32, device=dev)
            g.faces = wp.zeros(1, dtype=wp.int32, device=dev)
            self.gpu = g
            return
        if not dev.is_cpu:
            raise ValueError("WideBVH is the CPU tracer's; on CUDA the tracer uses Warp's own queries")
        # Warp's tree has fewer than 2 T nodes; a 4-wide one has at most as many nodes and leaves.
        cap = 2 * triangles
        children = wp.empty(WIDTH * cap, dtype=wp.int32, device=dev)
        source = wp.empty(WIDTH * cap, dtype=wp.int32, device=dev)
        leaves = wp.empty(2 * cap, dtype=wp.int32, device=dev)
        counts = wp.zeros(2, dtype=wp.int32, device=dev)
        wp.launch(collapse_kernel, 1, [wp.uint64(mesh.id), children, source, leaves, counts], device=dev)
        nodes, leaf_count = (int(v) for v in counts.numpy())
        if nodes <= 0:
            raise ValueError(f"the mesh's BVH is deeper than a {WIDTH}-wide copy can hold")
        self._source = wp.array(source.numpy()[: WIDTH * nodes], dtype=wp.int32, device=dev)
        g.children = wp.array(children.numpy()[: WIDTH * nodes], dtype=wp.int32, device=dev)
        g.leaves = wp.array(leaves.numpy()[: 2 * leaf_count], dtype=wp.int32, device=dev)
        g.boxes = wp.empty(24 * nodes, dtype=wp.float32, device=dev)
        g.corners = wp.empty(9 * triangles, dtype=wp.float32, device=dev)
        g.faces = wp.empty(triangles, dtype=wp.int32, device=dev)
        g.nodes = nodes
        self.gpu = g
        self.refit()

    @property
    def node_count(self) -> int:
        """4-wide nodes (0 for an empty tree)."""
        return int(self.gpu.nodes)

    def refit(self) -> None:
        """Copy the mesh's boxes and corners again (after ``wp.Mesh.refit``)."""
        if self.gpu.nodes == 0:
            return
        g, dev, mid = self.gpu, self.mesh.device, wp.uint64(self.mesh.id)
        wp.launch(node_boxes_kernel, g.nodes, [mid, self._source, g.boxes], device=dev)
        wp.launch(leaf_corners_kernel, g.faces.shape[0], [mid, g.corners, g.faces], device=dev)
