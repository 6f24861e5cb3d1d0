"""The 4-wide BVH copy answers every ray query as Warp's own query on the same mesh does
(CPU only: the tracer's CUDA variant keeps Warp's queries)."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.scene.device.wide_bvh import WideBVH, WideBVHGPU, wide_any_hit, wide_closest

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


def _assert_same_answers(mesh: wp.Mesh, wide: WideBVH, o: np.ndarray, d: np.ndarray, max_t: np.ndarray) -> None:
    warp_hit, warp_n, warp_block = _queries(_warp_queries, wp.uint64(mesh.id), o, d, max_t)
    wide_hit, wide_n, wide_block = _queries(_wide_queries, wide.gpu, o, d, max_t)
    np.testing.assert_array_equal(wide_block, warp_block)
    np.testing.assert_array_equal(wide_hit[:, 0] >= 0, warp_hit[:, 0] >= 0)
    np.testing.assert_array_equal(wide_hit[:, 1], warp_hit[:, 1])  # the nearest distance, always
    same = wide_hit[:, 0] == warp_hit[:, 0]
    # another face only in a tie: at the same distance (a shared edge or vertex)
    assert (~same).sum() <= 0.01 * len(o)
    np.testing.assert_array_equal(wide_hit[same], warp_hit[same])
    hit = same & (warp_hit[:, 0] >= 0)
    np.testing.assert_array_equal(wide_n[hit], warp_n[hit])


def test_queries_answer_as_warps_own() -> None:
    """Closest hits (face, distance, barycentrics, normal) and any-hits equal Warp's on
    random, axis-aligned, edge-grazing and zero-length rays and segments."""
    rng = np.random.default_rng(7)
    points, indices = _test_mesh(rng)
    mesh = wp.Mesh(wp.array(points, dtype=wp.vec3, device=CPU), wp.array(indices.ravel(), dtype=wp.int32, device=CPU))
    wide = WideBVH(mesh, len(indices))
    assert 0 < wide.node_count < len(indices)
    o, d, max_t = _rays(rng, 40000)
    _assert_same_answers(mesh, wide, o, d, max_t)
    warp_hit = _queries(_warp_queries, wp.uint64(mesh.id), o, d, max_t)[0]
    assert 0.2 < (warp_hit[:, 0] >= 0).mean() < 0.9  # the rays hit and miss


def test_a_refit_copies_the_moved_boxes_and_corners() -> None:
    """After the points move and the mesh is refitted, ``refit`` brings the copy to the
    mesh's answers again; without it the copy answers for the old points."""
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


@pytest.mark.parametrize(("triangles", "leaf_size"), [(1, 4), (3, 4), (5, 4), (7, 8), (9, 16)])
def test_a_mesh_of_one_node(triangles: int, leaf_size: int) -> None:
    """A mesh whose whole tree is one node answers as Warp's, with leaves of one to nine
    triangles (a leaf's triangles are tested four at a time, the last group short)."""
    rng = np.random.default_rng(triangles)
    points = rng.uniform(0.0, 1.0, (3 * triangles, 3)).astype(np.float32)
    indices = np.arange(3 * triangles, dtype=np.int32)
    mesh = wp.Mesh(
        wp.array(points, dtype=wp.vec3, device=CPU),
        wp.array(indices, dtype=wp.int32, device=CPU),
        bvh_leaf_size=leaf_size,
    )
    wide = WideBVH(mesh, triangles)
    assert wide.node_count == 1
    if leaf_size > 4:  # one leaf of more than four triangles: two or three groups
        assert wide.gpu.leaves.numpy().tolist() == [0, triangles]
    o = rng.uniform(-0.5, 1.5, (4000, 3)).astype(np.float32)
    d = (0.5 - o) + rng.normal(0.0, 0.3, (4000, 3)).astype(np.float32)
    d = (d / np.linalg.norm(d, axis=1)[:, None]).astype(np.float32)
    _assert_same_answers(mesh, wide, o, d, np.full(4000, 1.0e30, np.float32))


def test_an_empty_copy_misses_everything() -> None:
    wide = WideBVH(None, 0)
    assert wide.node_count == 0
    o = np.zeros((8, 3), np.float32)
    d = np.tile(np.array([[0.0, 0.0, 1.0]], np.float32), (8, 1))
    hits, _normals, blocked = _queries(_wide_queries, wide.gpu, o, d, np.full(8, 1.0e30, np.float32))
    assert (hits[:, 0] == -1).all() and (blocked == 0).all()
    wide.refit()  # nothing to copy
