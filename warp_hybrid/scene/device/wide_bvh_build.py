"""Building the 4-wide BVH copies (``wide_bvh.py``): a binned SAH binary tree over a
mesh's triangles, collapsed into 4-wide nodes, and the refit that computes every box
from the current points.

The binary tree (``build_kernel``, one thread, native code) is top-down binned SAH after
Wald's "On fast Construction of SAH-based Bounding Volume Hierarchies" (2007) and pbrt-v4's
``BVHAggregate``: each node bins its triangles' centroids into ``BINS`` bins along each of
the three axes and takes the plane of least surface-area cost, a node visit costing
``TRAVERSAL_COST`` and each group of four leaf triangles ``GROUP_COST`` (the traversal
tests a node's four boxes, and a leaf's triangles, four at a time); a node of at most
``MAX_LEAF`` triangles becomes a leaf where no plane is cheaper than testing them all.
Warp's own CPU build (``wp.Mesh``, which the CUDA queries and ``--bvh warp`` keep) bins
only the longest axis into 16 bins and splits down to its leaf size whatever the cost;
the copies queried this tree's shape answer the same rays 1.1-1.3x faster (README, "4-wide
BVH copies").  No binary node is deeper than ``MAX_DEPTH`` (a deeper one becomes a leaf),
so no 4-wide one is, and the traversal's stack (``wide_bvh.STACK_SIZE``) never fills.

The collapse (``collapse_kernel``) takes a binary node's children, then the children of
its largest child (by surface area), until there are four or only leaves, numbering the
4-wide nodes as it meets them, so a node's children always have larger numbers than the
node: ``refit_kernel`` (one thread) copies the triangles' corners from the points, then
computes the boxes from the last node to the first, each leaf child's box from its
triangles' corners and each node child's as the union of that node's four.  The build
itself ends with the same launch, so the boxes have one rule.  A refit keeps the tree's
shape (animated points: the boxes grow looser as the points move from where they were
built, the answers stay exact); given the points that moved, it touches only their
triangles, their leaves and the nodes above them (a small moving mesh in a large scene:
microseconds instead of a sweep over every triangle).
"""

from __future__ import annotations

import warp as wp

#: Bins per axis of the SAH split search.
BINS = 32
#: A node visit's cost, against ``GROUP_COST`` for each group of four leaf triangles.
TRAVERSAL_COST = 1.0
#: The cost of testing four of a leaf's triangles at once.
GROUP_COST = 1.0
#: The most triangles a leaf holds unless a node is at ``MAX_DEPTH`` (the SAH decides below).
MAX_LEAF = 8
#: Floats a 4-wide node takes (``wide_bvh.WideBVHGPU.node_data``): 24 of boxes, 4 children
#: (int32 bits) from ``CHILD_LANES``, 4 unused: 128 bytes.
NODE_FLOATS = 32
CHILD_LANES = 24
#: A child slot's entry for no child (and the native code's spelling of it).
NO_CHILD = -(2**31)
NO_CHILD_C = f"(int){NO_CHILD & 0xFFFFFFFF:#x}"
#: The deepest a binary node may be (depth 0 is the root; a build may ask for less); a
#: node there is a leaf, however many triangles it holds.
MAX_DEPTH = 60

wp.set_module_options({"enable_backward": False})


def slot_lane_cpp(slot: str) -> str:
    """C++ of where slot ``slot``'s lane starts in the corners (``wide_bvh.WideBVHGPU.corners``:
    four slots to a group of 36 floats, each axis of each corner a row of four lanes), in
    floats: its corner c's axis a is ``4 (3 c + a)`` floats on."""
    return f"(9 * (({slot}) & ~3) + (({slot}) & 3))"


_BUILD = """
#if !defined(__CUDA_ARCH__)
const int T = tri_count;
const float* P = (const float*)points.data;
const int* I = indices.data;
float* tb = tri_box.data;
int* ord = order.data;
const float inf = __builtin_inff();
for (int f = 0; f < T; ++f) {
    float* b = tb + 6 * f;
    for (int a = 0; a < 3; ++a) { b[a] = inf; b[3 + a] = -inf; }
    for (int c = 0; c < 3; ++c) {
        const float* p = P + 3 * I[3 * f + c];
        for (int a = 0; a < 3; ++a) { b[a] = wp::min(b[a], p[a]); b[3 + a] = wp::max(b[3 + a], p[a]); }
    }
    ord[f] = f;
}
auto area = [](const float* lo, const float* hi) {
    const float x = hi[0] - lo[0], y = hi[1] - lo[1], z = hi[2] - lo[2];
    return x * y + y * z + z * x;
};
auto leaf_cost = [&](int n) { return (float)((n + 3) / 4) * GROUP_COST; };
auto bin_of = [&](const float* b, int a, float c0, float scale) {
    const int k = (int)((0.5f * (b[a] + b[3 + a]) - c0) * scale);
    return k < 0 ? 0 : (k >= BINS ? BINS - 1 : k);
};
int st_node[2 * MAX_DEPTH + 2], st_start[2 * MAX_DEPTH + 2], st_end[2 * MAX_DEPTH + 2], st_depth[2 * MAX_DEPTH + 2];
st_node[0] = 0; st_start[0] = 0; st_end[0] = T; st_depth[0] = 0;
int sp = 1, nodes = 1;
while (sp > 0) {
    --sp;
    const int node = st_node[sp], start = st_start[sp], end = st_end[sp], depth = st_depth[sp];
    float* nb = node_box.data + 6 * node;
    float clo[3] = {inf, inf, inf}, chi[3] = {-inf, -inf, -inf};
    for (int a = 0; a < 3; ++a) { nb[a] = inf; nb[3 + a] = -inf; }
    for (int i = start; i < end; ++i) {
        const float* b = tb + 6 * ord[i];
        for (int a = 0; a < 3; ++a) {
            nb[a] = wp::min(nb[a], b[a]);
            nb[3 + a] = wp::max(nb[3 + a], b[3 + a]);
            const float c = 0.5f * (b[a] + b[3 + a]);
            clo[a] = wp::min(clo[a], c);
            chi[a] = wp::max(chi[a], c);
        }
    }
    const int n = end - start;
    int best_axis = -1, best_bin = -1;
    float best_cost = inf;
    if (n > 1 && depth < max_depth) {
        const float node_area = area(nb, nb + 3);
        for (int a = 0; a < 3; ++a) {
            if (!(chi[a] > clo[a])) continue;
            const float scale = (float)BINS / (chi[a] - clo[a]);
            int count[BINS];
            float lo[BINS][3], hi[BINS][3];
            for (int k = 0; k < BINS; ++k) {
                count[k] = 0;
                for (int q = 0; q < 3; ++q) { lo[k][q] = inf; hi[k][q] = -inf; }
            }
            for (int i = start; i < end; ++i) {
                const float* b = tb + 6 * ord[i];
                const int k = bin_of(b, a, clo[a], scale);
                ++count[k];
                for (int q = 0; q < 3; ++q) { lo[k][q] = wp::min(lo[k][q], b[q]); hi[k][q] = wp::max(hi[k][q], b[3 + q]); }
            }
            // the cost of the planes after bins 0..BINS-2: right-hand sums first, then a sweep from the left
            float right_area[BINS];
            int right_count[BINS];
            float rlo[3] = {inf, inf, inf}, rhi[3] = {-inf, -inf, -inf};
            int rn = 0;
            for (int k = BINS - 1; k > 0; --k) {
                rn += count[k];
                for (int q = 0; q < 3; ++q) { rlo[q] = wp::min(rlo[q], lo[k][q]); rhi[q] = wp::max(rhi[q], hi[k][q]); }
                right_area[k] = rn > 0 ? area(rlo, rhi) : 0.0f;
                right_count[k] = rn;
            }
            float llo[3] = {inf, inf, inf}, lhi[3] = {-inf, -inf, -inf};
            int ln = 0;
            for (int k = 0; k < BINS - 1; ++k) {
                ln += count[k];
                for (int q = 0; q < 3; ++q) { llo[q] = wp::min(llo[q], lo[k][q]); lhi[q] = wp::max(lhi[q], hi[k][q]); }
                if (ln == 0 || right_count[k + 1] == 0) continue;
                const float cost = TRAVERSAL_COST + (area(llo, lhi) * leaf_cost(ln)
                    + right_area[k + 1] * leaf_cost(right_count[k + 1])) / node_area;
                if (cost < best_cost) { best_cost = cost; best_axis = a; best_bin = k; }
            }
        }
    }
    // a leaf: one triangle, the deepest level, or at most max_leaf where no plane pays (or none
    // separates the centroids)
    const bool leaf = n <= 1 || depth >= max_depth || (n <= max_leaf && (best_axis < 0 || best_cost >= leaf_cost(n)));
    if (leaf) {
        node_a.data[node] = -(start + 1);
        node_b.data[node] = end;
        continue;
    }
    int mid = (start + end) / 2;  // every centroid in one place: split the list in half
    if (best_axis >= 0) {
        const int a = best_axis;
        const float scale = (float)BINS / (chi[a] - clo[a]);
        int i = start, j = end - 1;
        while (i <= j) {
            if (bin_of(tb + 6 * ord[i], a, clo[a], scale) <= best_bin) {
                ++i;
            } else {
                const int t = ord[i]; ord[i] = ord[j]; ord[j] = t; --j;
            }
        }
        mid = i;
    }
    const int left = nodes++, right = nodes++;
    node_a.data[node] = left;
    node_b.data[node] = right;
    st_node[sp] = right; st_start[sp] = mid; st_end[sp] = end; st_depth[sp] = depth + 1; ++sp;
    st_node[sp] = left; st_start[sp] = start; st_end[sp] = mid; st_depth[sp] = depth + 1; ++sp;
}
#endif
"""
for _name, _value in (
    ("BINS", BINS),
    ("TRAVERSAL_COST", f"{TRAVERSAL_COST}f"),
    ("GROUP_COST", f"{GROUP_COST}f"),
    ("MAX_DEPTH", MAX_DEPTH),
):
    _BUILD = _BUILD.replace(_name, str(_value))


@wp.func_native(_BUILD)
def _build(
    points: wp.array(dtype=wp.vec3),
    indices: wp.array(dtype=wp.int32),
    tri_count: int,
    max_leaf: int,
    max_depth: int,
    tri_box: wp.array(dtype=wp.float32),
    order: wp.array(dtype=wp.int32),
    node_box: wp.array(dtype=wp.float32),
    node_a: wp.array(dtype=wp.int32),
    node_b: wp.array(dtype=wp.int32),
): ...


@wp.kernel
def build_kernel(
    points: wp.array(dtype=wp.vec3),
    indices: wp.array(dtype=wp.int32),
    tri_count: int,
    max_leaf: int,
    max_depth: int,
    tri_box: wp.array(dtype=wp.float32),
    order: wp.array(dtype=wp.int32),
    node_box: wp.array(dtype=wp.float32),
    node_a: wp.array(dtype=wp.int32),
    node_b: wp.array(dtype=wp.int32),
):
    """The binary SAH tree over ``tri_count`` triangles (one thread; module docstring),
    leaves of at most ``max_leaf`` triangles above depth ``max_depth`` (<= ``MAX_DEPTH``).
    Node 0 is the root; ``node_box``: 6 floats a node (low x, y, z, high x, y, z); an inner
    node's children are ``node_a``, ``node_b``, a leaf holds ``order[start:end]`` with
    ``node_a = -(start + 1)``, ``node_b = end``; ``order``: the faces in leaf order;
    ``tri_box``: scratch, 6 floats a triangle."""
    _build(points, indices, tri_count, max_leaf, max_depth, tri_box, order, node_box, node_a, node_b)


@wp.func_native(
    """
#if !defined(__CUDA_ARCH__)
int wide = 1, leaf_count = 0;
int work_node[4 * MAX_DEPTH + 4], work_slot[4 * MAX_DEPTH + 4], top = 1;
auto is_leaf = [&](int k) { return node_a.data[k] < 0; };
auto area = [&](int k) {
    const float* b = node_box.data + 6 * k;
    const float x = b[3] - b[0], y = b[4] - b[1], z = b[5] - b[2];
    return x * y + y * z + z * x;
};
work_node[0] = 0; work_slot[0] = 0;
while (top > 0) {
    --top;
    const int node = work_node[top], slot = work_slot[top];
    int kids[4], n = 0;
    if (is_leaf(node)) {
        kids[n++] = node;
    } else {
        kids[n++] = node_a.data[node];
        kids[n++] = node_b.data[node];
    }
    while (n < 4) {
        int big = -1;
        for (int j = 0; j < n; ++j)
            if (!is_leaf(kids[j]) && (big < 0 || area(kids[j]) > area(kids[big]))) big = j;
        if (big < 0) break;
        const int split = kids[big];
        kids[big] = node_a.data[split];
        kids[n++] = node_b.data[split];
    }
    for (int j = 0; j < 4; ++j) {
        const int at = 4 * slot + j;
        if (j >= n) { children.data[at] = NO_CHILD; continue; }
        if (is_leaf(kids[j])) {
            leaves.data[2 * leaf_count] = -node_a.data[kids[j]] - 1;
            leaves.data[2 * leaf_count + 1] = node_b.data[kids[j]];
            children.data[at] = -(leaf_count + 1);
            ++leaf_count;
        } else {
            children.data[at] = wide;
            work_node[top] = kids[j]; work_slot[top] = wide; ++top;
            ++wide;
        }
    }
}
counts.data[0] = wide;
counts.data[1] = leaf_count;
#endif
""".replace("MAX_DEPTH", str(MAX_DEPTH)).replace("NO_CHILD", NO_CHILD_C)
)
def _collapse(
    node_box: wp.array(dtype=wp.float32),
    node_a: wp.array(dtype=wp.int32),
    node_b: wp.array(dtype=wp.int32),
    children: wp.array(dtype=wp.int32),
    leaves: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
): ...


@wp.kernel
def collapse_kernel(
    node_box: wp.array(dtype=wp.float32),
    node_a: wp.array(dtype=wp.int32),
    node_b: wp.array(dtype=wp.int32),
    children: wp.array(dtype=wp.int32),
    leaves: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
):
    """Collapse the binary tree into 4-wide nodes (one thread): ``children`` and ``leaves``
    as ``WideBVHGPU`` holds them, ``counts`` (nodes, leaves).  The work stack holds at
    most three entries a level (``MAX_DEPTH`` levels)."""
    _collapse(node_box, node_a, node_b, children, leaves, counts)


@wp.func_native(
    """
#if !defined(__CUDA_ARCH__)
const float inf = __builtin_inff();
const float* P = (const float*)points.data;
const int* I = indices.data;
const unsigned char* m = moved.data;
unsigned char* dirty = triangle_dirty.data;
float* tc = corners.data;
const int T = faces.shape[0];
for (int k = 0; k < T; ++k) {
    const int* f = I + 3 * faces.data[k];
    dirty[k] = every || m[f[0]] || m[f[1]] || m[f[2]];
    if (!dirty[k]) continue;
    float* group = tc + SLOT_K;  // slot k's lane of its group of four
    for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a) group[4 * (3 * c + a)] = P[3 * f[c] + a];
}
unsigned char* changed = node_changed.data;
for (int node = nodes - 1; node >= 0; --node) {
    float* b = node_data.data + NODE_FLOATS * node;
    const int* children = (const int*)(b + CHILD_LANES);
    changed[node] = 0;
    for (int j = 0; j < 4; ++j) {
        float lo[3] = {inf, inf, inf}, hi[3] = {-inf, -inf, -inf};
        const int c = children[j];
        if (c == NO_CHILD) {
            if (!every) continue;
        } else if (c < 0) {
            const int leaf = -c - 1, first = leaves.data[2 * leaf], end = leaves.data[2 * leaf + 1];
            bool stale = false;
            for (int t = first; t < end && !stale; ++t) stale = dirty[t];
            if (!stale) continue;
            for (int t = first; t < end; ++t)
                for (int v = 0; v < 3; ++v)
                    for (int a = 0; a < 3; ++a) {
                        const float x = tc[SLOT_T + 4 * (3 * v + a)];
                        lo[a] = wp::min(lo[a], x);
                        hi[a] = wp::max(hi[a], x);
                    }
        } else {
            if (!changed[c]) continue;
            const float* cb = node_data.data + NODE_FLOATS * c;
            for (int a = 0; a < 3; ++a)
                for (int q = 0; q < 4; ++q) {
                    lo[a] = wp::min(lo[a], cb[4 * a + q]);
                    hi[a] = wp::max(hi[a], cb[12 + 4 * a + q]);
                }
        }
        for (int a = 0; a < 3; ++a) { b[4 * a + j] = lo[a]; b[12 + 4 * a + j] = hi[a]; }
        changed[node] = 1;
    }
}
#endif
""".replace("NODE_FLOATS", str(NODE_FLOATS))
    .replace("CHILD_LANES", str(CHILD_LANES))
    .replace("NO_CHILD", NO_CHILD_C)
    .replace("SLOT_K", slot_lane_cpp("k"))
    .replace("SLOT_T", slot_lane_cpp("t"))
)
def _refit(
    points: wp.array(dtype=wp.vec3),
    indices: wp.array(dtype=wp.int32),
    faces: wp.array(dtype=wp.int32),
    moved: wp.array(dtype=wp.uint8),
    every: int,
    corners: wp.array(dtype=wp.float32),
    node_data: wp.array(dtype=wp.float32),
    leaves: wp.array(dtype=wp.int32),
    nodes: int,
    triangle_dirty: wp.array(dtype=wp.uint8),
    node_changed: wp.array(dtype=wp.uint8),
): ...


@wp.kernel
def refit_kernel(
    points: wp.array(dtype=wp.vec3),
    indices: wp.array(dtype=wp.int32),
    faces: wp.array(dtype=wp.int32),
    moved: wp.array(dtype=wp.uint8),
    every: int,
    corners: wp.array(dtype=wp.float32),
    node_data: wp.array(dtype=wp.float32),
    leaves: wp.array(dtype=wp.int32),
    nodes: int,
    triangle_dirty: wp.array(dtype=wp.uint8),
    node_changed: wp.array(dtype=wp.uint8),
):
    """The tree's corners and boxes from the points (one thread).  With ``every`` != 0,
    all of them: each slot's three corners (``wide_bvh.WideBVHGPU.corners``: in leaf order,
    each axis of a corner a lane of its group of four) copied from the points, then every node's four child boxes, the last node first: a leaf's from its
    triangles' corners, a node's as the union of its own four, an unused slot an inverted
    box no ray enters (the children are read from the node itself).  Otherwise only what
    the points flagged in ``moved`` (one byte a point) change: the corners of the
    slots whose triangle touches one (flagged in ``triangle_dirty``), the boxes of the leaves that
    hold one and of the nodes above them (``node_changed``); every other box already holds
    what the whole refit would write, so the result is the same bit for bit."""
    _refit(points, indices, faces, moved, every, corners, node_data, leaves, nodes, triangle_dirty, node_changed)
