"""The order a still mesh's triangles and points are stored in (``scene.usd.triangle_order``):
compact runs for the raster pass, and nothing drawn changes."""

from __future__ import annotations

import numpy as np
from pxr import Gf, UsdLux

from tests.scene.usd.render_kit import add_camera, render_aovs
from tests.scene.usd.usd_stage_kit import add_mesh, new_stage
from warp_hybrid.core.constants import CLUSTER_TRIANGLES
from warp_hybrid.scene.open import open_scene_source
from warp_hybrid.scene.usd import loader
from warp_hybrid.scene.usd.loader import load_scene
from warp_hybrid.scene.usd.meshes import WorldMesh
from warp_hybrid.scene.usd.triangle_order import (
    MIN_GAIN,
    coherent_order,
    morton_order,
    reorder_part,
    runs_extent,
    triangle_boxes,
)

# A bumpy 24 x 24 grid of quads (1152 triangles, 18 runs) over [-1, 1]^2 at z = 0.
GRID = 24


def grid_mesh() -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 3), quads (Q, 4)) of the bumpy grid, rows of quads in order."""
    u = np.linspace(-1.0, 1.0, GRID + 1)
    x, y = np.meshgrid(u, u)
    z = 0.05 * np.sin(5.0 * x) * np.cos(4.0 * y)
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(GRID), np.arange(GRID))
    k = (j * (GRID + 1) + i).ravel()
    quads = np.stack([k, k + 1, k + GRID + 2, k + GRID + 1], axis=1)
    return points, quads


def triangles_of(quads: np.ndarray) -> np.ndarray:
    """(2Q, 3) counter-clockwise triangles of the quads, each quad's two together."""
    return np.stack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1).reshape(-1, 3)


def shuffled(rows: np.ndarray, seed: int = 7) -> np.ndarray:
    """``rows`` in a random order (a scanner's or a converter's order: none)."""
    return rows[np.random.default_rng(seed).permutation(len(rows))]


def world_mesh(points: np.ndarray, tri: np.ndarray) -> WorldMesh:
    """A single mesh of ``tri`` over ``points`` with distinct corner data per triangle."""
    t = len(tri)
    normals = np.zeros((t, 3, 3), dtype=np.float32)
    normals[..., 2] = 1.0
    normals[:, :, 0] = np.arange(t, dtype=np.float32)[:, None] * 1e-4
    uvs = np.arange(t * 6, dtype=np.float32).reshape(t, 3, 2)
    colours = np.arange(t * 9, dtype=np.float32).reshape(t, 3, 3)
    return WorldMesh(points, tri.astype(np.int32), normals, uvs, 1, colours)


def test_morton_order_sorts_a_grid_along_the_z_curve() -> None:
    """On a 4 x 4 grid of cell centres the order is the Z curve: 2 x 2 blocks in turn."""
    centres = np.array([(x, y, 0.0) for y in range(4) for x in range(4)], dtype=np.float64)
    order = morton_order(centres)
    assert sorted(order.tolist()) == list(range(16))
    first_block = {tuple(centres[i][:2]) for i in order[:4]}
    assert first_block == {(0, 0), (1, 0), (0, 1), (1, 1)}
    assert [tuple(centres[i][:2]) for i in order[:4]] == [(0, 0), (1, 0), (0, 1), (1, 1)]


def test_a_coherent_mesh_and_a_small_one_keep_their_order() -> None:
    """A grid stored row by row is compact already: no reordering, nor below two runs."""
    points, quads = grid_mesh()
    assert coherent_order(points, triangles_of(quads)) is None
    small = shuffled(triangles_of(quads))[: 2 * CLUSTER_TRIANGLES - 1]
    assert coherent_order(points, small) is None


def test_a_mesh_with_a_non_finite_point_keeps_its_order() -> None:
    """A NaN or infinite corner (which validation reports, naming the mesh) leaves the
    authored order: no order is computed from it."""
    points, quads = grid_mesh()
    tri = shuffled(triangles_of(quads))
    for bad in (np.nan, np.inf):
        broken = points.copy()
        broken[tri[5, 1]] = (bad, 0.0, 0.0)
        assert coherent_order(broken, tri) is None
    assert coherent_order(points, tri) is not None


def test_a_shuffled_mesh_gets_compact_runs() -> None:
    """The shuffled grid's runs span the whole grid; in the new order they shrink by far
    more than ``MIN_GAIN``, and the order is a permutation of the triangles."""
    points, quads = grid_mesh()
    tri = shuffled(triangles_of(quads))
    order = coherent_order(points, tri)
    assert order is not None
    assert np.array_equal(np.sort(order), np.arange(len(tri)))
    before, after = runs_extent(*triangle_boxes(points, tri)), runs_extent(*triangle_boxes(points, tri[order]))
    assert after * MIN_GAIN <= before
    assert after < 0.4 * before  # (18 runs of 64 triangles: patches of about 8 x 4 quads, not the whole grid)


def test_reorder_part_keeps_every_triangle_its_corners_and_data() -> None:
    """Each triangle keeps its corners in order (the winding), its normals, uvs, colours and
    material; the points are those of the mesh, in the order the triangles first use them,
    an unused point after them."""
    points, quads = grid_mesh()
    points = np.concatenate([points, [[9.0, 9.0, 9.0]]])  # (a point no triangle uses)
    tri = shuffled(triangles_of(quads))
    world = world_mesh(points, tri)
    material = np.arange(len(tri), dtype=np.int32) % 5
    ordered, ordered_material = reorder_part(world, material)
    assert ordered is not world
    assert ordered.instances == 1
    # the same triangles, each with its data: matched by the corners' coordinates
    before = {tuple(points[t].ravel()): k for k, t in enumerate(tri)}
    seen = set()
    for k, t in enumerate(ordered.tri_points):
        src = before[tuple(ordered.points[t].ravel())]
        seen.add(src)
        assert np.array_equal(ordered.corner_normals[k], world.corner_normals[src])
        assert np.array_equal(ordered.corner_uvs[k], world.corner_uvs[src])
        assert np.array_equal(ordered.corner_colors[k], world.corner_colors[src])
        assert ordered_material[k] == material[src]
    assert len(seen) == len(tri)
    # the points: a permutation, first used in order, the unused one last
    assert np.array_equal(np.sort(ordered.points, axis=0), np.sort(points, axis=0))
    first_use = np.unique(ordered.tri_points.ravel(), return_index=True)[1]
    assert np.all(np.diff(first_use) > 0)
    assert np.array_equal(ordered.points[-1], [9.0, 9.0, 9.0])


def test_reorder_part_leaves_instances_and_coherent_meshes_alone() -> None:
    """An instanced batch and a compact mesh come back as the very same objects."""
    points, quads = grid_mesh()
    coherent = world_mesh(points, triangles_of(quads))
    material = np.zeros(len(coherent.tri_points), dtype=np.int32)
    assert reorder_part(coherent, material) == (coherent, material)
    tri = shuffled(triangles_of(quads))
    batch = world_mesh(np.concatenate([points, points + 3.0]), np.concatenate([tri, tri + len(points)]))
    batch.instances = 2
    material = np.zeros(len(batch.tri_points), dtype=np.int32)
    out, out_material = reorder_part(batch, material)
    assert out is batch and out_material is material


def write_grid_stage(tmp_path, animate: bool = False):
    """A stage of the shuffled bumpy grid facing a camera at z = 3 (time-sampled points
    where ``animate``)."""
    stage, path = new_stage(tmp_path)
    points, quads = grid_mesh()
    quads = shuffled(quads)
    mesh = add_mesh(stage, "/World/Grid", points, [4] * len(quads), quads.ravel())
    if animate:
        attr = mesh.GetPointsAttr()
        for t in (0.0, 1.0):
            attr.Set([Gf.Vec3f(*map(float, p + [0.0, 0.0, 0.1 * t])) for p in points], t)
    mesh.CreateDisplayColorAttr([(0.8, 0.6, 0.4)])
    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(3.0)
    sun.AddRotateXYZOp().Set(Gf.Vec3f(-30.0, 20.0, 0.0))
    add_camera(stage, 3.0)
    stage.GetRootLayer().Save()
    return path


def test_the_loader_orders_a_still_mesh_and_draws_the_same_image(tmp_path, monkeypatch) -> None:
    """A still mesh authored in no order is stored with compact runs, and its raster frame
    (every AOV) is the same bit for bit as with the authored order."""
    path = write_grid_stage(tmp_path)
    scene = load_scene(str(path))
    corners = scene.points[scene.indices].astype(np.float64)
    monkeypatch.setattr(loader, "reorder_part", lambda world, material: (world, material))
    authored = load_scene(str(path))
    authored_corners = authored.points[authored.indices].astype(np.float64)
    extent = runs_extent(*triangle_boxes(scene.points, scene.indices))
    assert extent * MIN_GAIN <= runs_extent(*triangle_boxes(authored.points, authored.indices))
    assert sorted(map(tuple, corners.reshape(-1, 9))) == sorted(map(tuple, authored_corners.reshape(-1, 9)))
    ordered_aovs, authored_aovs = render_aovs(scene), render_aovs(authored)
    assert (ordered_aovs["depth"] < np.inf).mean() > 0.5  # (the grid fills most of the view)
    for name, image in authored_aovs.items():
        assert np.array_equal(ordered_aovs[name], image, equal_nan=True), name


def test_a_mesh_whose_points_vary_keeps_its_authored_order(tmp_path) -> None:
    """Time-sampled points: the authored triangle order at every time (later times patch
    the arrays in place), while the points move."""
    path = write_grid_stage(tmp_path, animate=True)
    source = open_scene_source(str(path))
    first, later = source.scene_at(0.0), source.scene_at(1.0)
    _, quads = grid_mesh()
    assert np.array_equal(first.indices, triangles_of(shuffled(quads)))
    assert np.array_equal(later.indices, first.indices)
    assert np.allclose(later.points[:, 2] - first.points[:, 2], 0.1)
