"""The 4-wide BVH answers every ray query as Warp's own query on the same mesh does,
whatever the shape of its own tree (CPU only: the tracer's CUDA variant keeps Warp's
queries)."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.scene.device.wide_bvh import (
    PACKET,
    WideBVH,
    WideBVHGPU,
    grouped_leaves,
    packet_any_hits,
    packet_closest_hits,
    wide_any_hit,
    wide_closest,
)
from warp_hybrid.scene.device.wide_bvh_build import MAX_LEAF

CPU = "cpu"


@wp.kernel
def _warp_queries(
    mesh: wp.uint64,
    o: wp.array(dtype=wp.vec3),
    d: wp.array(dtype=wp.vec3),
    max_t: wp.array(dtype=float),
    hits: wp.array(dtype=wp.vec4),
    normals: wp.array(dtype=wp.vec3),
    blocked: wp.array(dtype=wp.int32),
):
    i = wp.tid()
    q = wp.mesh_query_ray(mesh, o[i], d[i], max_t[i])
    hits[i] = wp.vec4(-1.0, 0.0, 0.0, 0.0)
    if q.result:
        hits[i] = wp.vec4(float(q.face), q.t, q.u, q.v)
        normals[i] = q.normal
    blocked[i] = wp.where(wp.mesh_query_ray_anyhit(mesh, o[i], d[i], max_t[i]), 1, 0)


@wp.kernel
def _wide_queries(
    bvh: WideBVHGPU,
    o: wp.array(dtype=wp.vec3),
    d: wp.array(dtype=wp.vec3),
    max_t: wp.array(dtype=float),
    hits: wp.array(dtype=wp.vec4),
    normals: wp.array(dtype=wp.vec3),
    blocked: wp.array(dtype=wp.int32),
):
    i = wp.tid()
    q = wide_closest(bvh, o[i], d[i], max_t[i])
    hits[i] = wp.vec4(-1.0, 0.0, 0.0, 0.0)
    if q.result:
        hits[i] = wp.vec4(float(q.face), q.t, q.u, q.v)
        normals[i] = q.normal
    blocked[i] = wp.where(wide_any_hit(bvh, o[i], d[i], max_t[i]), 1, 0)


def _packet_blocked(wide: WideBVH, o: np.ndarray, d: np.ndarray, max_t: np.ndarray) -> np.ndarray:
    """``wide_any_hit_packet``'s answers for consecutive packets of the rays."""
    n = len(o)
    blocked = wp.full(n, -1, dtype=wp.int32, device=CPU)
    inputs = [wp.array(o, dtype=wp.vec3, device=CPU), wp.array(d, dtype=wp.vec3, device=CPU)]
    inputs.append(wp.array(max_t, dtype=wp.float32, device=CPU))
    wp.launch(packet_any_hits, -(-n // PACKET), [wide.gpu, *inputs, blocked], device=CPU)
    return blocked.numpy()


def _packet_closest(wide: WideBVH, o: np.ndarray, d: np.ndarray, max_t: np.ndarray) -> tuple:
    """``wide_closest_packet``'s hits (face, t, u, v) and normals for consecutive packets of the rays."""
    n = len(o)
    hits = wp.zeros(n, dtype=wp.vec4, device=CPU)
    normals = wp.zeros(n, dtype=wp.vec3, device=CPU)
    inputs = [wp.array(o, dtype=wp.vec3, device=CPU), wp.array(d, dtype=wp.vec3, device=CPU)]
    inputs.append(wp.array(max_t, dtype=wp.float32, device=CPU))
    wp.launch(packet_closest_hits, -(-n // PACKET), [wide.gpu, *inputs, hits, normals], device=CPU)
    return hits.numpy(), normals.numpy()


def _queries(kernel: wp.Kernel, first: object, o: np.ndarray, d: np.ndarray, max_t: np.ndarray) -> tuple:
    n = len(o)
    hits = wp.zeros(n, dtype=wp.vec4, device=CPU)
    normals = wp.zeros(n, dtype=wp.vec3, device=CPU)
    blocked = wp.zeros(n, dtype=wp.int32, device=CPU)
    inputs = [wp.array(o, dtype=wp.vec3, device=CPU), wp.array(d, dtype=wp.vec3, device=CPU)]
    inputs.append(wp.array(max_t, dtype=wp.float32, device=CPU))
    wp.launch(kernel, n, [first, *inputs, hits, normals, blocked], device=CPU)
    return hits.numpy(), normals.numpy(), blocked.numpy()


def _grid(n: int, z: float) -> tuple[np.ndarray, np.ndarray]:
    """An n x n grid of unit squares (two triangles each, shared edges) in the plane z."""
    xs, ys = np.meshgrid(np.arange(n + 1, dtype=np.float32), np.arange(n + 1, dtype=np.float32))
    points = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, z, np.float32)], axis=1)
    k = np.arange(n)[None, :] + (n + 1) * np.arange(n)[:, None]
    a, b, c, e = k.ravel(), k.ravel() + 1, k.ravel() + n + 2, k.ravel() + n + 1
    return points, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, e], 1)]).astype(np.int32)


def _test_mesh(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A triangle soup of 4000 small random triangles in [0, 16]^3 and two 16 x 16 grids
    (axis-aligned, shared edges: rays along their planes and through their edges)."""
    centres = rng.uniform(0.0, 16.0, (4000, 1, 3))
    soup = (centres + rng.normal(0.0, 0.4, (4000, 3, 3))).reshape(-1, 3).astype(np.float32)
    soup_idx = np.arange(len(soup), dtype=np.int32).reshape(-1, 3)
    g1, i1 = _grid(16, 4.0)
    g2, i2 = _grid(16, 12.0)
    points = np.concatenate([soup, g1, g2])
    indices = np.concatenate([soup_idx, i1 + len(soup), i2 + len(soup) + len(g1)])
    return points, indices


def _rays(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random rays from inside the box, a quarter of them axis-aligned (zero direction
    components) and from the grids' lattice points, half of them segments."""
    o = rng.uniform(-1.0, 17.0, (n, 3)).astype(np.float32)
    d = rng.normal(size=(n, 3))
    axis = rng.integers(0, 3, n // 4)
    d[: n // 4] = 0.0
    d[np.arange(n // 4), axis] = rng.choice([-1.0, 1.0], n // 4)
    o[: n // 8] = np.round(o[: n // 8])  # on the grids' vertices and edges
    d = (d / np.linalg.norm(d, axis=1)[:, None]).astype(np.float32)
    max_t = np.where(rng.random(n) < 0.5, rng.uniform(0.0, 8.0, n), 1.0e30).astype(np.float32)
    max_t[:16] = 0.0
    return o, d, max_t


def _mesh(points: np.ndarray, indices: np.ndarray) -> wp.Mesh:
    return wp.Mesh(wp.array(points, dtype=wp.vec3, device=CPU), wp.array(indices.ravel(), dtype=wp.int32, device=CPU))


def _assert_same_answers(mesh: wp.Mesh, wide: WideBVH, o: np.ndarray, d: np.ndarray, max_t: np.ndarray) -> None:
    warp_hit, warp_n, warp_block = _queries(_warp_queries, wp.uint64(mesh.id), o, d, max_t)
    wide_hit, wide_n, wide_block = _queries(_wide_queries, wide.gpu, o, d, max_t)
    np.testing.assert_array_equal(wide_block, warp_block)
    np.testing.assert_array_equal(_packet_blocked(wide, o, d, max_t), warp_block)
    packet_hit, packet_n = _packet_closest(wide, o, d, max_t)
    np.testing.assert_array_equal(packet_hit, wide_hit)  # the same hit bit for bit, a tie's face too
    found = wide_hit[:, 0] >= 0
    np.testing.assert_array_equal(packet_n[found], wide_n[found])
    np.testing.assert_array_equal(wide_hit[:, 0] >= 0, warp_hit[:, 0] >= 0)
    np.testing.assert_array_equal(wide_hit[:, 1], warp_hit[:, 1])  # the nearest distance, always
    same = wide_hit[:, 0] == warp_hit[:, 0]
    # another face only in a tie: at the same distance, on an edge or a corner both faces share
    corners = mesh.points.numpy()[mesh.indices.numpy().reshape(-1, 3)]
    ours, theirs = corners[wide_hit[~same, 0].astype(int)], corners[warp_hit[~same, 0].astype(int)]
    shares_a_corner = (ours[:, :, None, :] == theirs[:, None, :, :]).all(-1).any((1, 2))
    assert shares_a_corner.all()
    np.testing.assert_array_equal(wide_hit[same], warp_hit[same])
    hit = same & (warp_hit[:, 0] >= 0)
    np.testing.assert_array_equal(wide_n[hit], warp_n[hit])


def test_queries_answer_as_warps_own() -> None:
    """Closest hits (face, distance, barycentrics, normal) and any-hits equal Warp's on
    random, axis-aligned, edge-grazing and zero-length rays and segments."""
    rng = np.random.default_rng(7)
    points, indices = _test_mesh(rng)
    mesh = _mesh(points, indices)
    wide = WideBVH(mesh, len(indices))
    assert 0 < wide.node_count < len(indices)
    o, d, max_t = _rays(rng, 40000)
    _assert_same_answers(mesh, wide, o, d, max_t)
    warp_hit = _queries(_warp_queries, wp.uint64(mesh.id), o, d, max_t)[0]
    assert 0.2 < (warp_hit[:, 0] >= 0).mean() < 0.9  # the rays hit and miss


def test_packets_of_neighbouring_shadow_rays_answer_as_one_at_a_time() -> None:
    """Packets whose rays share a dominant axis (segments from a patch of points toward
    one light: the common case, its rays' coordinates permuted once), packets where one
    ray's axis differs, and packets with lanes that carry no ray (max_t 0, negative or
    NaN) give each ray the single-ray query's answer (and Warp's)."""
    rng = np.random.default_rng(13)
    points, indices = _test_mesh(rng)
    mesh = _mesh(points, indices)
    wide = WideBVH(mesh, len(indices))
    n = 8000
    xs, ys = np.meshgrid(np.linspace(0.5, 15.5, 100), np.linspace(0.5, 15.5, 80))
    o = np.stack([xs.ravel(), ys.ravel(), np.full(n, 12.5)], 1).astype(np.float32)
    light = np.array([8.0, 8.0, 30.0], np.float32)
    to = light - o
    max_t = np.linalg.norm(to, axis=1).astype(np.float32)
    d = (to / max_t[:, None]).astype(np.float32)
    d[5 :: PACKET * 3] = np.array([1.0, 0.0, 0.0], np.float32)  # one lane of some packets along x
    max_t[3 :: PACKET * 5] = 0.0
    max_t[4 :: PACKET * 7] = -1.0
    max_t[6 :: PACKET * 11] = np.nan
    blocked = _packet_blocked(wide, o, d, max_t)
    single = _queries(_wide_queries, wide.gpu, o, d, max_t)[2]
    np.testing.assert_array_equal(blocked, single)
    assert 0.2 < single.mean() < 0.9 and not blocked[np.isnan(max_t) | (max_t <= 0.0)].any()
    _assert_same_answers(mesh, wide, o, d, max_t)


def test_a_tie_goes_to_the_first_triangle_in_leaf_order() -> None:
    """Rays straight down through a grid's shared edges and corners meet two to six
    triangles at exactly the same distance: the single-ray and the packet query both
    answer the one first in the tree's leaf order, whatever order they visit the nodes in."""
    points, indices = _grid(16, 4.0)
    mesh = _mesh(points, indices)
    wide = WideBVH(mesh, len(indices))
    xs, ys = np.meshgrid(np.arange(1.0, 16.0, 0.5), np.arange(1.0, 16.0, 0.5))
    o = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, 10.0)], 1).astype(np.float32)
    d = np.tile(np.array([0.0, 0.0, -1.0], np.float32), (len(o), 1))
    max_t = np.full(len(o), 1.0e30, np.float32)
    single = _queries(_wide_queries, wide.gpu, o, d, max_t)[0]
    np.testing.assert_array_equal(_packet_closest(wide, o, d, max_t)[0], single)
    np.testing.assert_array_equal(single[:, 1], 6.0)
    # the triangles each ray's point lies in (on an edge or a corner: several), first in leaf order
    corners = points[indices].astype(np.float64)[None, :, :, :2]  # (1, T, 3, 2)
    p = o[:, None, None, :2].astype(np.float64)
    a, b, c = corners[:, :, 0], corners[:, :, 1], corners[:, :, 2]

    def edge(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return (v[..., 0] - u[..., 0]) * (p[:, :, 0, 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (
            p[:, :, 0, 0] - u[..., 0]
        )

    e = np.stack([edge(a, b), edge(b, c), edge(c, a)], -1)
    inside = (e >= 0.0).all(-1) | (e <= 0.0).all(-1)
    slot_of_face = np.empty(len(indices), np.int64)
    slot_of_face[wide.gpu.faces.numpy()] = np.arange(len(indices))
    slots = np.where(inside, slot_of_face[None, :], len(indices))
    expected = wide.gpu.faces.numpy()[slots.min(1)]
    assert (inside.sum(1) >= 2).all()  # every ray meets a tie
    np.testing.assert_array_equal(single[:, 0], expected)


def test_a_refit_copies_the_moved_boxes_and_corners() -> None:
    """After the points move, ``refit`` brings the tree to the (refitted) mesh's answers
    again; without it the tree answers for the old points."""
    rng = np.random.default_rng(3)
    points, indices = _test_mesh(rng)
    warp_points = wp.array(points, dtype=wp.vec3, device=CPU)
    mesh = wp.Mesh(warp_points, wp.array(indices.ravel(), dtype=wp.int32, device=CPU))
    wide = WideBVH(mesh, len(indices))
    o, d, max_t = _rays(rng, 20000)
    warp_points.assign(points * np.float32(0.8) + np.float32(1.5))
    mesh.refit()
    stale = _queries(_wide_queries, wide.gpu, o, d, max_t)[0]
    fresh = _queries(_warp_queries, wp.uint64(mesh.id), o, d, max_t)[0]
    assert (stale[:, 1] != fresh[:, 1]).mean() > 0.1
    wide.refit()
    _assert_same_answers(mesh, wide, o, d, max_t)


def _bits(a: wp.array) -> np.ndarray:
    return a.numpy().view(np.int32)


@pytest.mark.parametrize("share", [0.0, 0.002, 0.05, 1.0])
def test_a_refit_of_the_moved_points_alone_is_the_whole_refit(share: float) -> None:
    """Given the points that moved, ``refit`` redoes only their triangles' corners and the
    boxes above them, and leaves the tree bit for bit as a whole refit does (two moves in a
    row, the second from where the first left it); the rays then get the mesh's answers.
    A flag left off a moved point leaves its leaf's box stale (the test can fail)."""
    rng = np.random.default_rng(7)
    points, indices = _test_mesh(rng)
    warp_points = wp.array(points, dtype=wp.vec3, device=CPU)
    mesh = wp.Mesh(warp_points, wp.array(indices.ravel(), dtype=wp.int32, device=CPU))
    partial = WideBVH(mesh, len(indices))
    whole = WideBVH(mesh, len(indices))
    for _ in range(2):
        moved = rng.random(len(points)) < share
        points = points.copy()
        points[moved] += rng.normal(0.0, 0.3, (int(moved.sum()), 3)).astype(np.float32)
        warp_points.assign(points)
        partial.refit(moved)
        whole.refit()
        for name in ("node_data", "corners"):  # as bits: a node's child lanes are int32s
            assert np.array_equal(_bits(getattr(partial.gpu, name)), _bits(getattr(whole.gpu, name))), name
    mesh.refit()
    o, d, max_t = _rays(rng, 5000)
    _assert_same_answers(mesh, partial, o, d, max_t)
    if 0.0 < share < 1.0:
        first = int(np.flatnonzero(moved)[0])
        points[first] += np.float32(5.0)
        warp_points.assign(points)
        moved[first] = False
        partial.refit(moved)
        whole.refit()
        assert not np.array_equal(_bits(partial.gpu.node_data), _bits(whole.gpu.node_data))


def test_a_refit_refuses_a_moved_mask_of_another_length() -> None:
    rng = np.random.default_rng(8)
    points, indices = _test_mesh(rng)
    wide = WideBVH(_mesh(points, indices), len(indices))
    with pytest.raises(ValueError, match="one a point"):
        wide.refit(np.zeros(len(points) - 1, dtype=bool))


@pytest.mark.parametrize(("triangles", "max_leaf"), [(1, MAX_LEAF), (3, MAX_LEAF), (5, MAX_LEAF), (7, 8), (9, 16)])
def test_a_mesh_of_one_leaf(triangles: int, max_leaf: int) -> None:
    """Triangles that each span the unit cube (no plane separates them at a profit) make
    one leaf of one to nine triangles (tested four at a time, the last group short), and
    it answers as Warp's."""
    rng = np.random.default_rng(triangles)
    cube = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 1.0]], np.float32)
    points = (cube[None] + rng.uniform(-0.05, 0.05, (triangles, 3, 3))).reshape(-1, 3).astype(np.float32)
    mesh = _mesh(points, np.arange(3 * triangles, dtype=np.int32))
    wide = WideBVH(mesh, triangles, max_leaf=max_leaf)
    assert wide.node_count == 1
    assert wide.gpu.leaves.numpy().tolist() == [0, triangles]
    o = rng.uniform(-0.5, 1.5, (4000, 3)).astype(np.float32)
    d = (0.5 - o) + rng.normal(0.0, 0.3, (4000, 3)).astype(np.float32)
    d = (d / np.linalg.norm(d, axis=1)[:, None]).astype(np.float32)
    _assert_same_answers(mesh, wide, o, d, np.full(4000, 1.0e30, np.float32))


def test_a_row_of_triangles_is_cut_into_leaves_of_four_neighbours() -> None:
    """64 small triangles in a row, far apart: four of a leaf's triangles cost one test, so
    the SAH cuts the row into 16 leaves of four neighbours each; the answers are Warp's."""
    rng = np.random.default_rng(5)
    centres = np.stack([np.arange(64, dtype=np.float32) * 4.0, np.zeros(64), np.zeros(64)], 1)
    points = (centres[:, None, :] + rng.uniform(-0.5, 0.5, (64, 3, 3))).reshape(-1, 3).astype(np.float32)
    mesh = _mesh(points, np.arange(3 * 64, dtype=np.int32))
    wide = WideBVH(mesh, 64)
    leaves = wide.gpu.leaves.numpy().reshape(-1, 2)
    faces = wide.gpu.faces.numpy()
    assert len(leaves) == 16 and (np.diff(leaves, axis=1) == 4).all()
    assert all(np.ptp(faces[a:b]) == 3 for a, b in leaves)
    o = rng.uniform([-2.0, -3.0, -3.0], [256.0, 3.0, 3.0], (4000, 3)).astype(np.float32)
    d = rng.normal(size=(4000, 3))
    d = (d / np.linalg.norm(d, axis=1)[:, None]).astype(np.float32)
    _assert_same_answers(mesh, wide, o, d, np.full(4000, 1.0e30, np.float32))


@pytest.mark.parametrize("max_depth", [0, 2, 5])
def test_nodes_at_the_depth_limit_are_leaves_however_big(max_depth: int) -> None:
    """A tree cut at ``max_depth`` (``MAX_DEPTH`` bounds every build, so the traversal's
    stack never fills) ends there in leaves of more than ``MAX_LEAF`` triangles, and every
    query still answers as Warp's."""
    rng = np.random.default_rng(11)
    points, indices = _test_mesh(rng)
    mesh = _mesh(points, indices)
    wide = WideBVH(mesh, len(indices), max_depth=max_depth)
    leaves = wide.gpu.leaves.numpy().reshape(-1, 2)
    assert len(leaves) == 2**max_depth and np.diff(leaves, axis=1).min() > MAX_LEAF
    o, d, max_t = _rays(rng, 10000)
    _assert_same_answers(mesh, wide, o, d, max_t)


def test_leaves_are_laid_out_in_groups_of_four_slots() -> None:
    """Each leaf starts a group of four slots and fills whole groups, its spare slots
    repeating their group's first face; the slots keep the leaves' order in the face list
    (the tie rule's leaf order), whatever order the leaves are numbered in."""
    order = np.arange(100, 121, dtype=np.int32)  # 21 faces in leaf order
    spans = np.array([[9, 17], [0, 1], [17, 21], [1, 4], [4, 9]], np.int32)  # numbered out of place
    faces, grouped = grouped_leaves(order, spans)
    assert grouped.tolist() == [[16, 24], [0, 1], [24, 28], [4, 7], [8, 13]]
    assert faces.tolist() == [
        *[100, 100, 100, 100],  # one face, three spares
        *[101, 102, 103, 101],
        *[104, 105, 106, 107, 108, 108, 108, 108],
        *[109, 110, 111, 112, 113, 114, 115, 116],
        *[117, 118, 119, 120],
    ]


def test_corners_are_stored_a_lane_a_triangle() -> None:
    """Slot k's corner c, axis a is at ``9 (k & ~3) + 4 (3 c + a) + (k & 3)`` of ``corners``:
    a group's 36 floats hold each corner axis as four lanes, one a triangle."""
    rng = np.random.default_rng(4)
    points, indices = _test_mesh(rng)
    wide = WideBVH(_mesh(points, indices), len(indices))
    faces = wide.gpu.faces.numpy()
    corners = wide.gpu.corners.numpy()
    k = np.arange(len(faces))
    lanes = corners[(9 * (k & ~3) + (k & 3))[:, None, None] + 4 * (3 * np.arange(3)[:, None] + np.arange(3))]
    np.testing.assert_array_equal(lanes, points[indices[faces]])


def test_an_empty_copy_misses_everything() -> None:
    wide = WideBVH(None, 0)
    assert wide.node_count == 0
    o = np.zeros((8, 3), np.float32)
    d = np.tile(np.array([[0.0, 0.0, 1.0]], np.float32), (8, 1))
    hits, _normals, blocked = _queries(_wide_queries, wide.gpu, o, d, np.full(8, 1.0e30, np.float32))
    assert (hits[:, 0] == -1).all() and (blocked == 0).all()
    wide.refit()  # nothing to copy
