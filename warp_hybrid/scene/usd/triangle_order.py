"""The order of a still mesh's triangles and points: compact runs for the raster pass.

The coverage pass takes a scene's triangles in runs of ``CLUSTER_TRIANGLES`` consecutive
ones (``primary.kernels``): one box culls a run, and its triangles are set up together
and write their pixels' depth keys one after the other.  Where an authored mesh lists
its triangles in no spatial order (the glass dragon's 91k: the box of a run of 64 of
them spans 284 of the screen's 480 rows at the median), every run reaches across the
mesh, no run is culled, and every triangle's corners and keys lie far from the last
one's.  ``coherent_order`` then puts the triangles in the Morton (Z-curve) order of their
boxes' centres, and their points in the order the triangles first use them, so runs are
patches and neighbouring triangles read neighbouring corners (the glass dragon's runs
10x smaller; its raster frame 5.7% faster, the raster stage 1.13x and the surface pass
1.15x, docs/speed_journal.md, twentieth session).

A mesh keeps its authored order unless the Morton order makes its runs' boxes at least
``MIN_GAIN`` times smaller (the sum of their extents): a mesh authored in a coherent
order (a modelling tool's, a scanner's, a tessellator's) is left as it is, and so is
every mesh of fewer than two runs.  Only the order changes: each triangle keeps its
corners, their order (the winding), normals, uvs, colours and material, so what is drawn
is the same; where two surfaces tie exactly in depth (coplanar overlaps) the raster
pass's winner is the one first in the new order.  The loader orders still parts only
(``UsdSceneSource``: one order for every time code; a part whose points or transform
may vary keeps the authored order, so later times patch it in place), and not a
PointInstancer's batch of instances.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...core.constants import CLUSTER_TRIANGLES
from .meshes import WorldMesh

#: How many times smaller the runs' boxes must get for a mesh to be reordered.
MIN_GAIN = 2.0
#: Bits of a box centre's coordinate on each axis in its Morton code.
_MORTON_BITS = 10


def _spread_bits(v: np.ndarray) -> np.ndarray:
    """The low ``_MORTON_BITS`` bits of each of ``v`` (uint32) two zero bits apart."""
    v = (v | (v << np.uint32(16))) & np.uint32(0x030000FF)
    v = (v | (v << np.uint32(8))) & np.uint32(0x0300F00F)
    v = (v | (v << np.uint32(4))) & np.uint32(0x030C30C3)
    return (v | (v << np.uint32(2))) & np.uint32(0x09249249)


def morton_order(centres: np.ndarray) -> np.ndarray:
    """The permutation that sorts ``centres`` (N, 3) along the Morton curve over the cube
    around their bounding box (one scale on every axis: a flat mesh is ordered by its two
    long axes, not split by its thin one first; ties in their given order)."""
    lo = centres.min(axis=0)
    extent = max(float((centres.max(axis=0) - lo).max()), np.finfo(np.float64).tiny)
    top = (1 << _MORTON_BITS) - 1
    cells = np.clip(((centres - lo) / extent * top).astype(np.int32), 0, top).astype(np.uint32)
    codes = _spread_bits(cells[:, 0]) | (_spread_bits(cells[:, 1]) << np.uint32(1))
    codes |= _spread_bits(cells[:, 2]) << np.uint32(2)
    return np.argsort(codes, kind="stable")


def runs_extent(lower: np.ndarray, upper: np.ndarray) -> float:
    """The sum over runs of ``CLUSTER_TRIANGLES`` consecutive triangles (their boxes'
    corners ``lower``, ``upper`` (T, 3)) of the run's bounding box's width, height and depth."""
    starts = np.arange(0, len(lower), CLUSTER_TRIANGLES)
    return float((np.maximum.reduceat(upper, starts, axis=0) - np.minimum.reduceat(lower, starts, axis=0)).sum())


def triangle_boxes(points: np.ndarray, tri_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounding boxes (lower, upper (T, 3) float32) of the triangles ``tri_points``
    (T, 3) over ``points`` (N, 3)."""
    p = np.asarray(points, dtype=np.float32)
    a, b, c = (p[tri_points[:, k]] for k in range(3))
    return np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)


def coherent_order(points: np.ndarray, tri_points: np.ndarray) -> np.ndarray | None:
    """The order to store a mesh's triangles in (a permutation of its ``tri_points``
    (T, 3) rows, over ``points`` (N, 3)), or None where the authored order is kept (module
    docstring)."""
    if len(tri_points) < 2 * CLUSTER_TRIANGLES:
        return None
    lower, upper = triangle_boxes(points, tri_points)
    if not (np.isfinite(lower).all() and np.isfinite(upper).all()):
        return None  # (validation names the mesh; no order is worth computing)
    order = morton_order(lower + upper)  # (the boxes' centres, doubled: the order is the same)
    if runs_extent(lower[order], upper[order]) * MIN_GAIN > runs_extent(lower, upper):
        return None
    return order


def reorder_part(world: WorldMesh, triangle_material: np.ndarray) -> tuple[WorldMesh, np.ndarray]:
    """A single (not instanced) mesh and its per-triangle materials with the triangles in
    ``coherent_order`` and the points in the order the triangles first use them (points
    no triangle uses after them, as they were); the same objects where the order is kept."""
    order = coherent_order(world.points, world.tri_points) if world.instances == 1 else None
    if order is None:
        return world, triangle_material
    tri_points = world.tri_points[order]
    values, first_use = np.unique(tri_points.ravel(), return_index=True)
    used = values[np.argsort(first_use)]  # (first uses are distinct: no ties)
    unused = np.ones(len(world.points), dtype=bool)
    unused[used] = False
    point_order = np.concatenate([used, np.flatnonzero(unused)])
    new_index = np.empty(len(point_order), dtype=np.int64)
    new_index[point_order] = np.arange(len(point_order))
    ordered = replace(
        world,
        points=world.points[point_order],
        tri_points=new_index[tri_points].astype(world.tri_points.dtype),
        corner_normals=world.corner_normals[order],
        corner_uvs=world.corner_uvs[order],
        corner_colors=None if world.corner_colors is None else world.corner_colors[order],
    )
    return ordered, triangle_material[order]
