"""Subdivision surfaces: ``subdivisionScheme`` catmullClark, loop and bilinear refined
uniformly, with the authored creases and corners, in vectorised numpy.

No well-kept Python library refines with creases: trimesh's ``subdivide_loop``, Open3D
and libigl do smooth Loop (and midpoint) refinement without sharpness and no
Catmull-Clark, OpenSubdiv has no maintained Python binding (pyopensubdiv 0.0.3 dates from
2022) and usd-core ships no ``PxOsd`` module.  So the rules are written here, after
OpenSubdiv's ``Sdc`` (Pixar's reference for USD):

* Catmull-Clark: face points (the face's centroid), edge points
  (``(v0 + v1 + fa + fb) / 4``), vertex points (``(Q + 2R + (n - 3) v) / n``); one
  level turns an n-gon into n quads.  Loop (triangle meshes only): edge points
  ``3/8 (v0 + v1) + 1/8 (opposites)``, vertex points with Loop's beta; one level turns
  a triangle into four.  Bilinear: face centroids and edge midpoints, vertices stay.
* Sharpness (``creaseIndices`` / ``creaseLengths`` / ``creaseSharpnesses`` per crease
  or per edge, ``cornerIndices`` / ``cornerSharpnesses``): an edge of sharpness >= 1
  takes its midpoint, below 1 a blend of the smooth and the sharp point; a vertex with
  two sharp edges takes the crease rule ``(e1 + 6 v + e2) / 8``, more than two or a
  sharp corner stays put; a vertex whose rule changes from this level to the next
  blends both rules by its edges' (and corner's) fractional sharpness.  Children
  inherit sharpness minus one ("uniform" crease method); 10 and above is infinite.
* Boundaries: boundary and non-manifold edges are infinitely sharp; with
  ``interpolateBoundary`` edgeAndCorner (the default) a boundary vertex of one face is
  a corner too; ``none`` is drawn as edgeOnly (with a warning).
  ``triangleSubdivisionRule`` smooth is drawn with the catmullClark weights (warned).
* Primvars: vertex ones follow the points' refinement, varying ones the bilinear one,
  faceVarying ones are interpolated bilinearly within each face (as
  ``faceVaryingLinearInterpolation = all``), uniform ones follow the parent face.

The refinement is kept as one sparse linear operator per level (``Linear``), so the
points and every primvar of a mesh are refined by the same weights.

Level: meshes that author a scheme are refined ``levels`` times, fewer when one mesh
would exceed ``MAX_REFINED_FACES`` (2**21) faces (with a warning); the loader's default
chooses the level per mesh from its size on the screen (``subdivision_level.AUTO``);
``DEFAULT_LEVELS`` = 1 is the fixed level of a mesh read without a screen.  Meshes that leave ``subdivisionScheme`` unauthored (the USD fallback is
catmullClark) are drawn as polygon meshes, as before and as usdview draws every mesh at
its default complexity: refining them would change every scene that never asked for it.

``crease_normals`` gives a refined mesh smooth normals split along the edges that are
still sharp after the last level (remaining sharpness >= 1) and along non-manifold ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom

from .validate import Diagnostics

SCHEMES = (UsdGeom.Tokens.catmullClark, UsdGeom.Tokens.loop, UsdGeom.Tokens.bilinear)
DEFAULT_LEVELS = 1
MAX_REFINED_FACES = 1 << 21
INFINITE_SHARPNESS = 10.0  # PxOsd: a sharpness of 10 or more is infinitely sharp

_SMOOTH, _CREASE, _CORNER = 0, 1, 2


class Linear:
    """A sparse (rows, cols, weights) operator of shape ``(n_out, n_in)``: refined
    values are weighted sums of the values one level up."""

    def __init__(self, rows: np.ndarray, cols: np.ndarray, weights: np.ndarray, n_out: int, n_in: int) -> None:
        """Entries with the same (row, col) add up (``apply`` sums them)."""
        self.rows = np.asarray(rows, dtype=np.int64)
        self.cols = np.asarray(cols, dtype=np.int64)
        self.weights = np.asarray(weights, dtype=np.float64)
        self.n_out = n_out
        self.n_in = n_in

    def apply(self, values: np.ndarray) -> np.ndarray:
        """The operator applied to ``values`` (n_in, k), in float64 (n_out, k)."""
        values = np.asarray(values, dtype=np.float64).reshape(self.n_in, -1)
        taken = np.take(values, self.cols, axis=0) * self.weights[:, None]
        return np.stack(
            [np.bincount(self.rows, weights=taken[:, a], minlength=self.n_out) for a in range(values.shape[1])],
            axis=1,
        )


@dataclass(frozen=True)
class Sharpness:
    """Authored sharpness: ``edges`` (K, 2) vertex pairs with ``edge_sharpness`` (K,),
    ``corners`` (M,) vertices with ``corner_sharpness`` (M,) (``inf``: infinitely
    sharp); ``boundary_corners``: boundary vertices of one face are corners
    (``interpolateBoundary`` edgeAndCorner)."""

    edges: np.ndarray
    edge_sharpness: np.ndarray
    corners: np.ndarray
    corner_sharpness: np.ndarray
    boundary_corners: bool = True

    @staticmethod
    def smooth(boundary_corners: bool = True) -> Sharpness:
        """No creases and no corners."""
        empty = np.zeros(0, dtype=np.int64)
        return Sharpness(empty.reshape(0, 2), np.zeros(0), empty, np.zeros(0), boundary_corners)


@dataclass
class Refinement:
    """A refined mesh: the refined faces (``counts``, ``indices``), the
    control face of each (``face_parent``), the per-level operators for vertex,
    varying and faceVarying values, and the refined edges still sharp (``sharp_edges``
    (S, 2), for the normals).  ``unmatched_creases``: authored crease edges that are
    not edges of the mesh (ignored)."""

    counts: np.ndarray
    indices: np.ndarray
    face_parent: np.ndarray
    vertex: list[Linear]
    varying: list[Linear]
    face_varying: list[Linear]
    sharp_edges: np.ndarray
    control_points: int
    unmatched_creases: int = 0

    @staticmethod
    def _chain(ops: list[Linear], values: np.ndarray) -> np.ndarray:
        out = np.asarray(values, dtype=np.float64)
        width = out.shape[1:]
        for op in ops:
            out = op.apply(out)
        return out.reshape((-1,) + width)

    def vertex_values(self, values: np.ndarray) -> np.ndarray:
        """Values per control point (points, vertex primvars) at the refined points."""
        return self._chain(self.vertex, values)

    def varying_values(self, values: np.ndarray) -> np.ndarray:
        """Varying primvar values (linear over the faces) at the refined points."""
        return self._chain(self.varying, values)

    def face_varying_values(self, values: np.ndarray) -> np.ndarray:
        """Values per control face corner at the refined face corners."""
        return self._chain(self.face_varying, values)

    def refined_holes(self, holes: np.ndarray | None) -> np.ndarray | None:
        """The refined faces whose control face is in ``holes``."""
        if holes is None or not holes.size:
            return None
        return np.flatnonzero(np.isin(self.face_parent, holes))


# -- one level ------------------------------------------------------------------------------------


def _ranges(starts: np.ndarray, lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(owner, index): for each i, ``lengths[i]`` entries ``starts[i] + 0..lengths[i]-1``."""
    owner = np.repeat(np.arange(starts.size), lengths)
    first = np.cumsum(lengths) - lengths
    return owner, np.repeat(starts, lengths) + np.arange(owner.size) - np.repeat(first, lengths)


@dataclass
class _Level:
    """One level's mesh: faces, points, authored sharpness per edge key and per vertex."""

    counts: np.ndarray
    indices: np.ndarray
    n_points: int
    crease_keys: np.ndarray  # sorted keys a * n_points + b (a < b) of creased edges
    crease_sharpness: np.ndarray
    vertex_sharpness: np.ndarray

    def __post_init__(self) -> None:
        counts, n = self.counts, self.n_points
        self.offsets = np.cumsum(counts) - counts
        self.face_of = np.repeat(np.arange(counts.size), counts)
        pos = np.arange(self.indices.size) - self.offsets[self.face_of]
        size = counts[self.face_of]
        self.next = self.offsets[self.face_of] + (pos + 1) % size
        self.prev = self.offsets[self.face_of] + (pos - 1) % size
        a, b = self.indices, self.indices[self.next]
        keys, self.edge_of = np.unique(np.minimum(a, b) * n + np.maximum(a, b), return_inverse=True)
        self.edge_of = self.edge_of.reshape(-1)
        self.edges = np.stack([keys // n, keys % n], axis=1)
        self.edge_faces = np.bincount(self.edge_of, minlength=keys.size)
        self.crease = np.zeros(keys.size)
        if self.crease_keys.size and keys.size:
            at = np.clip(np.searchsorted(keys, self.crease_keys), 0, keys.size - 1)
            found = keys[at] == self.crease_keys
            np.maximum.at(self.crease, at[found], self.crease_sharpness[found])
            self.unmatched = int((~found).sum())
        else:
            self.unmatched = int(self.crease_keys.size)
        self.sharpness = np.where(self.edge_faces == 2, self.crease, np.inf)

    def corner_sharpness(self, boundary_corners: bool) -> np.ndarray:
        """Per-vertex sharpness: the authored one, infinite for isolated vertices and
        (``boundary_corners``) for boundary vertices of a single face."""
        n = self.n_points
        faces = np.bincount(self.indices, minlength=n)
        out = self.vertex_sharpness.copy()
        out[faces == 0] = np.inf
        if boundary_corners:
            boundary = np.zeros(n, dtype=bool)
            boundary[self.edges[self.edge_faces == 1].reshape(-1)] = True
            out[boundary & (faces == 1)] = np.inf
        return out

    def halves(self, edges: np.ndarray) -> np.ndarray:
        """The child edges (2K, 2) (low, high vertex) of the edges ``edges`` (K,): edge
        ``e``'s point is child vertex ``n_points + e``."""
        mid = self.n_points + edges
        return np.concatenate([np.stack([self.edges[edges, 0], mid], 1), np.stack([self.edges[edges, 1], mid], 1)])

    def child(self, counts: np.ndarray, indices: np.ndarray, n_points: int) -> _Level:
        """The next level (``n_points`` points): each creased edge's two halves and the
        corners keep their sharpness minus one."""
        keep = np.flatnonzero(self.crease > 1.0)
        pairs = self.halves(keep)
        keys = pairs[:, 0] * n_points + pairs[:, 1]
        sharp = np.tile(self.crease[keep] - 1.0, 2)
        order = np.argsort(keys)
        vertex = np.zeros(n_points)
        vertex[: self.n_points] = np.maximum(self.vertex_sharpness - 1.0, 0.0)
        return _Level(counts, indices, n_points, keys[order], sharp[order], vertex)

    def sharp_children(self) -> np.ndarray:
        """The child edges (S, 2) still sharp after this level (sharpness >= 1 left)
        or non-manifold: where the refined mesh's normals split."""
        return self.halves(np.flatnonzero((self.crease >= 2.0) | (self.edge_faces > 2)))


def _vertex_rule(corner: np.ndarray, sharp_edges: np.ndarray) -> np.ndarray:
    return np.where(corner | (sharp_edges > 2), _CORNER, np.where(sharp_edges == 2, _CREASE, _SMOOTH))


def _vertex_weights(
    lv: _Level, corner_sharpness: np.ndarray, smooth_self: np.ndarray, smooth_other: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The vertex points' weights: on the vertex itself (N,), on the other end of each
    edge end ((2, 2E) vertex and other end, weights (2E,)), and the smooth rule's share
    (N,) (its face weights are the caller's).  The rule at this level and at the next
    are blended by the fractional sharpness (OpenSubdiv's
    ``ComputeFractionalWeightAtVertex``)."""
    n = lv.n_points
    vert = lv.edges.reshape(-1)
    other = lv.edges[:, ::-1].reshape(-1)
    es = np.repeat(lv.sharpness, 2)
    parts = []
    for threshold in (0.0, 1.0):
        sharp = es > threshold
        rule = _vertex_rule(corner_sharpness > threshold, np.bincount(vert, weights=sharp, minlength=n))
        self_w = np.choose(rule, [smooth_self, np.full(n, 0.75), np.ones(n)])
        end_rule = rule[vert]
        end_w = np.where(end_rule == _SMOOTH, smooth_other[vert], np.where(end_rule == _CREASE, 0.125 * sharp, 0.0))
        parts.append((rule, self_w, end_w))
    (rule_p, self_p, end_p), (rule_c, self_c, end_c) = parts
    t_vertex = (corner_sharpness > 0) & (corner_sharpness <= 1)
    t_edge = (es > 0) & (es <= 1)
    total = np.where(t_vertex, corner_sharpness, 0.0) + np.bincount(
        vert, weights=np.where(t_edge, es, 0.0), minlength=n
    )
    count = t_vertex + np.bincount(vert, weights=t_edge, minlength=n)
    alpha = np.where(rule_p == rule_c, 1.0, np.clip(total / np.maximum(count, 1), 0.0, 1.0))
    alpha_end = alpha[vert]
    self_w = alpha * self_p + (1 - alpha) * self_c
    end_w = alpha_end * end_p + (1 - alpha_end) * end_c
    smooth_share = alpha * (rule_p == _SMOOTH) + (1 - alpha) * (rule_c == _SMOOTH)
    return self_w, np.stack([vert, other]), end_w, smooth_share


def _vertex_rows(
    lv: _Level, boundary_corners: bool, linear: bool, smooth_self: np.ndarray, smooth_other: np.ndarray
) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray], np.ndarray]:
    """The vertex points' (rows, cols, weights) over the points, and each vertex's share
    of the smooth rule (which also weighs the faces around it); ``linear``: they stay."""
    n = lv.n_points
    if linear:
        return [np.arange(n)], [np.arange(n)], [np.ones(n)], np.zeros(n)
    self_w, (vert, other), end_w, smooth = _vertex_weights(
        lv, lv.corner_sharpness(boundary_corners), smooth_self, smooth_other
    )
    return [np.arange(n), vert], [np.arange(n), other], [self_w, end_w], smooth


def _catmull_clark(lv: _Level, boundary_corners: bool, linear: bool) -> Linear:
    """One Catmull-Clark (``linear``: bilinear) level's operator.  Refined points: vertex
    points, then one per edge, then one per face."""
    n, e, f = lv.n_points, lv.edges.shape[0], lv.counts.size
    n_out = n + e + f
    inv_count = 1.0 / lv.counts
    rows, cols, weights = [], [], []

    def face_point(row: np.ndarray, face: np.ndarray, w: np.ndarray) -> None:
        owner, corner = _ranges(lv.offsets[face], lv.counts[face])
        rows.append(row[owner])
        cols.append(lv.indices[corner])
        weights.append((w * inv_count[face])[owner])

    face_point(n + e + np.arange(f), np.arange(f), np.ones(f))
    t = np.ones(e) if linear else np.minimum(lv.sharpness, 1.0)
    for end in range(2):
        rows.append(n + np.arange(e))
        cols.append(lv.edges[:, end])
        weights.append((1 - t) / 4 + t / 2)
    corner_t = t[lv.edge_of]
    face_point(n + lv.edge_of, lv.face_of, (1 - corner_t) / 4)
    valence = np.maximum(np.bincount(lv.edges.reshape(-1), minlength=n), 1).astype(np.float64)
    v_rows, v_cols, v_weights, smooth = _vertex_rows(lv, boundary_corners, linear, (valence - 2) / valence, valence**-2)
    rows, cols, weights = rows + v_rows, cols + v_cols, weights + v_weights
    if smooth.any():
        face_point(lv.indices, lv.face_of, (smooth / valence**2)[lv.indices])
    return Linear(np.concatenate(rows), np.concatenate(cols), np.concatenate(weights), n_out, n)


def _catmull_clark_faces(lv: _Level) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One Catmull-Clark level's quads (counts, indices) and their parent faces: one
    per corner, (vertex, its edge, the face, the previous edge)."""
    n, e = lv.n_points, lv.edges.shape[0]
    quads = np.stack([lv.indices, n + lv.edge_of, n + e + lv.face_of, n + lv.edge_of[lv.prev]], axis=1)
    return np.full(lv.indices.size, 4, dtype=np.int64), quads.reshape(-1), lv.face_of


def _loop(lv: _Level, boundary_corners: bool, linear: bool) -> Linear:
    """One Loop (``linear``: midpoint) level's operator on a triangle mesh.  Refined
    points: vertex points, then one per edge."""
    n, e = lv.n_points, lv.edges.shape[0]
    t = np.ones(e) if linear else np.minimum(lv.sharpness, 1.0)
    rows = [n + np.arange(e), n + np.arange(e), n + lv.edge_of]
    cols = [lv.edges[:, 0], lv.edges[:, 1], lv.indices[lv.prev]]
    weights = [(1 - t) * 3 / 8 + t / 2, (1 - t) * 3 / 8 + t / 2, (1 - t[lv.edge_of]) / 8]
    valence = np.maximum(np.bincount(lv.edges.reshape(-1), minlength=n), 1).astype(np.float64)
    beta = (5 / 8 - (3 / 8 + np.cos(2 * np.pi / valence) / 4) ** 2) / valence
    v_rows, v_cols, v_weights, _smooth = _vertex_rows(lv, boundary_corners, linear, 1 - valence * beta, beta)
    rows, cols, weights = rows + v_rows, cols + v_cols, weights + v_weights
    return Linear(np.concatenate(rows), np.concatenate(cols), np.concatenate(weights), n + e, n)


def _loop_faces(lv: _Level) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One Loop level's triangles (counts, indices) and their parent faces: each
    triangle's corner children first (vertex, its edge, the previous edge), then the
    middle ones (its three edges)."""
    n, f = lv.n_points, lv.counts.size
    corner_tris = np.stack([lv.indices, n + lv.edge_of, n + lv.edge_of[lv.prev]], axis=1)
    tris = np.concatenate([corner_tris, (n + lv.edge_of).reshape(f, 3)])
    return np.full(tris.shape[0], 3, dtype=np.int64), tris.reshape(-1), np.concatenate([lv.face_of, np.arange(f)])


def _face_varying(lv: _Level, loop: bool) -> Linear:
    """Bilinear interpolation of per-corner values onto the child faces' corners, in
    the child face order of ``_catmull_clark`` / ``_loop``."""
    c = lv.indices.size
    r = np.arange(c)
    half = np.full(c, 0.5)
    if loop:
        per = 3  # (c, mid(c, next), mid(prev, c)) per corner, then the middle triangles
        rows = [per * r, per * r + 1, per * r + 1, per * r + 2, per * r + 2]
        cols = [r, r, lv.next, lv.prev, r]
        weights = [np.ones(c), half, half, half, half]
        middle = 3 * c + r  # middle triangle of face f: mid(o, o+1), mid(o+1, o+2), mid(o+2, o)
        rows += [middle, middle]
        cols += [r, lv.next]
        weights += [half, half]
        return Linear(np.concatenate(rows), np.concatenate(cols), np.concatenate(weights), 4 * c, c)
    per = 4  # (c, mid(c, next), centroid, mid(prev, c)) per corner
    owner, corner = _ranges(lv.offsets[lv.face_of], lv.counts[lv.face_of])
    rows = [per * r, per * r + 1, per * r + 1, per * r + 3, per * r + 3, per * owner + 2]
    cols = [r, r, lv.next, lv.prev, r, corner]
    weights = [np.ones(c), half, half, half, half, 1.0 / lv.counts[lv.face_of][owner]]
    return Linear(np.concatenate(rows), np.concatenate(cols), np.concatenate(weights), per * c, c)


def refined_face_count(scheme: str, counts: np.ndarray, levels: int) -> int:
    """How many faces ``levels`` levels of ``scheme`` make of the faces ``counts``."""
    if levels <= 0:
        return int(counts.size)
    first = 4 * counts.size if scheme == UsdGeom.Tokens.loop else int(counts.sum())
    return first * 4 ** (levels - 1)


def refine(
    scheme: str, counts: np.ndarray, indices: np.ndarray, n_points: int, sharpness: Sharpness, levels: int
) -> Refinement:
    """Refine the faces ``counts`` over ``indices`` (of ``n_points`` points) ``levels``
    times with ``scheme`` (``SCHEMES``; loop needs triangles).  Faces with fewer than
    three vertices take no part (their corners have no refined corners)."""
    counts = np.asarray(counts, dtype=np.int64)
    indices = np.asarray(indices, dtype=np.int64)
    loop = scheme == UsdGeom.Tokens.loop
    linear = scheme == UsdGeom.Tokens.bilinear
    operator, faces = (_loop, _loop_faces) if loop else (_catmull_clark, _catmull_clark_faces)
    face_parent = np.flatnonzero(counts >= 3)
    face_varying: list[Linear] = []
    if face_parent.size < counts.size:  # drop degenerate faces and their corners
        offsets = np.cumsum(counts) - counts
        _owner, kept = _ranges(offsets[face_parent], counts[face_parent])
        face_varying.append(Linear(np.arange(kept.size), kept, np.ones(kept.size), kept.size, indices.size))
        counts, indices = counts[face_parent], indices[kept]
    edges = np.sort(np.asarray(sharpness.edges, dtype=np.int64).reshape(-1, 2), axis=1)
    keys = edges[:, 0] * n_points + edges[:, 1]
    order = np.argsort(keys)
    vertex_sharp = np.zeros(n_points)
    np.maximum.at(vertex_sharp, sharpness.corners, sharpness.corner_sharpness)
    lv = _Level(counts, indices, n_points, keys[order], np.asarray(sharpness.edge_sharpness)[order], vertex_sharp)
    unmatched = lv.unmatched
    if linear:  # every control edge is a crease of the bilinear surface (for the normals)
        lv.crease = lv.sharpness = np.full(lv.edges.shape[0], np.inf)
    vertex: list[Linear] = []
    varying: list[Linear] = []
    sharp_edges = np.zeros((0, 2), dtype=np.int64)
    for level in range(levels):
        op = operator(lv, sharpness.boundary_corners, linear)
        vertex.append(op)
        varying.append(op if linear else operator(lv, sharpness.boundary_corners, True))
        face_varying.append(_face_varying(lv, loop))
        counts, indices, parent = faces(lv)
        face_parent = face_parent[parent]
        if level + 1 < levels:
            lv = lv.child(counts, indices, op.n_out)
        else:
            sharp_edges = lv.sharp_children()
    return Refinement(counts, indices, face_parent, vertex, varying, face_varying, sharp_edges, n_points, unmatched)


# -- normals ------------------------------------------------------------------------------------


def crease_normals(
    points: np.ndarray, refinement: Refinement, tri_corner: np.ndarray, tri_cross: np.ndarray, tri_face: np.ndarray
) -> np.ndarray:
    """Unit corner normals (T, 3, 3) of the refined triangles: area-weighted normals of
    the faces around each vertex, split along ``refinement.sharp_edges``.  ``tri_corner``
    indexes the refined corners, ``tri_cross`` (T, 3) are the triangles' edge cross
    products and ``tri_face`` their refined faces."""
    counts, indices = refinement.counts, refinement.indices
    n = len(points)
    face_normal = np.stack([np.bincount(tri_face, weights=tri_cross[:, a], minlength=counts.size) for a in range(3)], 1)
    lv = _Level(counts, indices, n, np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(n))
    sharp = np.sort(refinement.sharp_edges, axis=1)
    keys = lv.edges[:, 0] * n + lv.edges[:, 1]
    smooth = np.flatnonzero((lv.edge_faces == 2) & ~np.isin(keys, sharp[:, 0] * n + sharp[:, 1]))
    by_edge = np.argsort(lv.edge_of, kind="stable")
    first = np.cumsum(lv.edge_faces) - lv.edge_faces
    c, d = by_edge[first[smooth]], by_edge[first[smooth] + 1]  # the two corners starting each smooth edge
    same = indices[c] == indices[d]  # both faces run the edge the same way (inconsistent winding)
    left = np.concatenate([c, lv.next[c]])
    right = np.concatenate([np.where(same, d, lv.next[d]), np.where(same, lv.next[d], d)])
    label = np.arange(indices.size)
    while True:  # fans of corners joined across smooth edges: each takes its smallest corner index
        low = np.minimum(label[left], label[right])
        new = label.copy()
        np.minimum.at(new, left, low)
        np.minimum.at(new, right, low)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    corner_normal = face_normal[lv.face_of]
    fan = np.stack([np.bincount(label, weights=corner_normal[:, a], minlength=indices.size) for a in range(3)], 1)
    normal = fan[label]
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = normal / np.where(length > 0, length, 1.0)
    return np.take(normal, tri_corner, axis=0).astype(np.float32)


# -- reading a mesh's subdivision -----------------------------------------------------------------


def _int_array(prim: Usd.Prim, name: str, authored: frozenset[str], time: Usd.TimeCode) -> np.ndarray:
    value = prim.GetAttribute(name).Get(time) if name in authored else None
    return np.asarray(value if value is not None else [], dtype=np.int64).reshape(-1)


def _float_array(prim: Usd.Prim, name: str, authored: frozenset[str], time: Usd.TimeCode) -> np.ndarray:
    value = prim.GetAttribute(name).Get(time) if name in authored else None
    return np.asarray(value if value is not None else [], dtype=np.float64).reshape(-1)


def _sharpness_values(values: np.ndarray) -> np.ndarray:
    """Authored sharpness: 10 and above infinite, negative values smooth."""
    return np.where(values >= INFINITE_SHARPNESS, np.inf, np.maximum(values, 0.0))


def _creases(
    prim: Usd.Prim, authored: frozenset[str], time: Usd.TimeCode, n_points: int, diag: Diagnostics, name: str
) -> tuple[np.ndarray, np.ndarray]:
    """The authored crease edges (K, 2) and their sharpness (K,); empty (warned) when
    the crease attributes do not fit together or the points."""
    indices = _int_array(prim, "creaseIndices", authored, time)
    lengths = _int_array(prim, "creaseLengths", authored, time)
    sharp = _float_array(prim, "creaseSharpnesses", authored, time)
    none = np.zeros((0, 2), dtype=np.int64), np.zeros(0)
    if not indices.size and not lengths.size:
        return none
    problem = None
    edges_per = lengths - 1
    if lengths.size and lengths.min() < 2:
        problem = f"creaseLengths holds {int(lengths.min())}; every crease needs at least 2 vertices"
    elif int(lengths.sum()) != indices.size:
        problem = f"creaseLengths sum to {int(lengths.sum())} but creaseIndices has {indices.size} entries"
    elif indices.size and (indices.min() < 0 or indices.max() >= n_points):
        problem = f"creaseIndices reach outside the {n_points} points"
    elif sharp.size not in (lengths.size, int(edges_per.sum())):
        problem = (
            f"creaseSharpnesses has {sharp.size} values; expected {lengths.size} (one per crease) "
            f"or {int(edges_per.sum())} (one per crease edge)"
        )
    elif not np.isfinite(sharp).all():
        problem = "creaseSharpnesses holds NaN/Inf values"
    if problem is not None:
        diag.warn(f"{problem}; the creases are ignored", name)
        return none
    starts = np.cumsum(lengths) - lengths
    owner, first = _ranges(starts, edges_per)
    edges = np.stack([indices[first], indices[first + 1]], axis=1)
    per_edge = sharp if sharp.size == edges.shape[0] and sharp.size != lengths.size else sharp[owner]
    return edges, _sharpness_values(per_edge)


def _corners(
    prim: Usd.Prim, authored: frozenset[str], time: Usd.TimeCode, n_points: int, diag: Diagnostics, name: str
) -> tuple[np.ndarray, np.ndarray]:
    """The authored corner vertices and their sharpness; empty (warned) when they do
    not fit together or the points."""
    indices = _int_array(prim, "cornerIndices", authored, time)
    sharp = _float_array(prim, "cornerSharpnesses", authored, time)
    problem = None
    if indices.size != sharp.size:
        problem = f"cornerIndices has {indices.size} entries but cornerSharpnesses {sharp.size}"
    elif indices.size and (indices.min() < 0 or indices.max() >= n_points):
        problem = f"cornerIndices reach outside the {n_points} points"
    elif not np.isfinite(sharp).all():
        problem = "cornerSharpnesses holds NaN/Inf values"
    if problem is not None:
        diag.warn(f"{problem}; the corners are ignored", name)
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    return indices, _sharpness_values(sharp)


def authored_scheme(prim: Usd.Prim, authored: frozenset[str], time: Usd.TimeCode) -> str | None:
    """The mesh's authored ``subdivisionScheme``; None when it is not authored (drawn as
    a polygon mesh, see the module docs)."""
    if "subdivisionScheme" not in authored:
        return None
    attr = prim.GetAttribute("subdivisionScheme")
    return str(attr.Get(time)) if attr.HasAuthoredValue() else None


def read_refinement(
    prim: Usd.Prim,
    time: Usd.TimeCode,
    authored: frozenset[str],
    counts: np.ndarray,
    indices: np.ndarray,
    n_points: int,
    diag: Diagnostics,
    levels: int | Callable[[], int] = DEFAULT_LEVELS,
) -> Refinement | None:
    """The refinement of the mesh ``prim`` (faces ``counts`` over ``indices``) when it
    authors a subdivision scheme and ``levels`` > 0 (a callable: asked only then), else
    None (drawn as its control cage).  Loop on non-triangles, an unknown scheme and a mesh over the face budget
    are drawn as the cage with a warning naming the prim; bad crease or corner data is
    ignored with a warning."""
    name = str(prim.GetPath())
    scheme = authored_scheme(prim, authored, time)
    if scheme is None or scheme == UsdGeom.Tokens.none:
        return None
    if callable(levels):
        levels = levels()
    if levels <= 0:
        return None
    if scheme not in SCHEMES:
        diag.warn(f"subdivisionScheme {scheme!r} is not a USD scheme; rendered as its control cage", name)
        return None
    drawn = counts[counts >= 3]
    if scheme == UsdGeom.Tokens.loop and (drawn != 3).any():
        diag.warn("subdivisionScheme 'loop' needs a triangle mesh; rendered as its control cage", name)
        return None
    fitting = levels
    while fitting > 0 and refined_face_count(scheme, drawn, fitting) > MAX_REFINED_FACES:
        fitting -= 1
    if fitting < levels:
        diag.warn(
            f"subdivided {fitting} levels instead of {levels}: {levels} would make "
            f"{refined_face_count(scheme, drawn, levels)} faces (at most {MAX_REFINED_FACES})",
            name,
        )
        if fitting == 0:
            return None
    boundary = prim.GetAttribute("interpolateBoundary").Get(time) if "interpolateBoundary" in authored else None
    if boundary == UsdGeom.Tokens.none:
        diag.warn("interpolateBoundary 'none' is not supported; its boundary is interpolated as edgeOnly", name)
    if "triangleSubdivisionRule" in authored and (
        prim.GetAttribute("triangleSubdivisionRule").Get(time) == UsdGeom.Tokens.smooth
    ):
        diag.warn("triangleSubdivisionRule 'smooth' is not supported; triangles take the catmullClark weights", name)
    edges, edge_sharpness = _creases(prim, authored, time, n_points, diag, name)
    corners, corner_sharpness = _corners(prim, authored, time, n_points, diag, name)
    boundary_corners = boundary in (None, UsdGeom.Tokens.edgeAndCorner)
    sharpness = Sharpness(edges, edge_sharpness, corners, corner_sharpness, boundary_corners)
    refinement = refine(scheme, counts, indices, n_points, sharpness, fitting)
    if refinement.unmatched_creases:
        diag.warn(f"crease edges that are not edges of the mesh are ignored ({refinement.unmatched_creases})", name)
    return refinement
