"""UsdGeom.Mesh -> triangles with per-corner normals and uvs, then into world space.

Reading is split in two so instances and static meshes are cheap:

* ``read_local_mesh`` turns one mesh prim into a ``LocalMesh`` in its own space:
  polygons of any size triangulated (a reshape when all faces are triangles, a
  vectorised fan for convex polygons, ear clipping for the rare concave ones), faces
  listed in ``holeIndices`` dropped, ``leftHanded`` winding flipped so that every
  triangle is counter-clockwise seen from its front.  Normals come from
  ``primvars:normals`` over ``normals`` (constant/uniform/vertex/varying/faceVarying,
  indexed or not), else smooth area-weighted vertex normals are computed; NaN/Inf
  authored normals raise ``SceneError`` naming the prim (as NaN/Inf points do),
  zero-length ones become the geometric (face) normal.
* A mesh that authors ``subdivisionScheme`` catmullClark, loop or bilinear is refined
  first (``subdivision``): its refined faces are triangulated, ``tri_face`` still names
  the control face (material subsets, uniform primvars), primvars are refined with the
  points (``LocalMesh.refinement``), and normals are computed from the refined points,
  split along the creases still sharp (authored normals are ignored, as USD specifies
  for subdivision surfaces).  Skinned points (``skel``) replace the authored points
  before that; their normals are computed too (authored ones would need skinning).
* ``to_world`` applies one or many local-to-world matrices (instances) in a batch:
  points by the matrix (in float64, kept so), normals by its inverse transpose, and
  the winding flipped again where a matrix mirrors (negative determinant).

UVs (``corner_uvs``) read the primvar a material asks for (``st`` by default), with
any interpolation.  Everything is numpy; no Python loop runs per triangle.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from pxr import Sdf, Usd, UsdGeom

from ...errors import SceneError
from .subdivision import DEFAULT_LEVELS, Refinement, crease_normals, read_refinement
from .subdivision_level import LevelChooser
from .validate import Diagnostics, check_points, check_primvar, check_topology


class MalformedMeshError(SceneError):
    """A mesh whose topology cannot be drawn (bad counts, indices outside the points);
    the loader skips such a mesh with a warning unless it is strict."""


_UV_TYPES = {
    Sdf.ValueTypeNames.TexCoord2fArray,
    Sdf.ValueTypeNames.Float2Array,
    Sdf.ValueTypeNames.TexCoord2dArray,
    Sdf.ValueTypeNames.Double2Array,
    Sdf.ValueTypeNames.TexCoord2hArray,
    Sdf.ValueTypeNames.Half2Array,
}


@dataclass
class LocalMesh:
    """One mesh prim triangulated in its own (local) space.

    ``tri_corner`` (T, 3) indexes ``faceVertexIndices`` (so faceVarying data maps
    directly), ``tri_points`` (T, 3) indexes ``points``, ``tri_face`` (T,) is the
    source polygon of each triangle.  ``corner_normals`` (T, 3, 3) are unit length.
    ``time_varying``: points, topology or normals may change over time.  ``authored``
    names the prim's properties that have opinions; ``uvs`` caches corner uvs by
    primvar name.  A subdivided mesh has its ``refinement``: ``points`` and
    ``tri_corner`` / ``tri_points`` are then the refined mesh's, ``tri_face``,
    ``face_count`` and ``face_vertex_count`` still the control mesh's.
    """

    prim_path: str
    points: np.ndarray
    tri_corner: np.ndarray
    tri_points: np.ndarray
    tri_face: np.ndarray
    corner_normals: np.ndarray
    face_count: int
    face_vertex_count: int
    double_sided: bool
    time_varying: bool
    authored: frozenset[str] = frozenset()
    uvs: dict[str, np.ndarray] = field(default_factory=dict)
    refinement: Refinement | None = None

    @property
    def triangle_count(self) -> int:
        """Number of triangles."""
        return int(self.tri_points.shape[0])


# -- triangulation -------------------------------------------------------------------


def triangulate(
    counts: np.ndarray, face_vertex_indices: np.ndarray, points: np.ndarray, holes: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate polygons given by ``counts`` over ``face_vertex_indices``.

    Returns ``(tri_corner, tri_face)``: each triangle's three positions in
    ``face_vertex_indices`` (same winding as the polygon) and its polygon index.
    Faces with fewer than 3 vertices and faces in ``holes`` produce no triangles.
    Convex polygons are fanned from their first vertex; concave ones are ear-clipped.
    """
    counts = np.asarray(counts, dtype=np.int64)
    n_faces = counts.size
    keep = counts >= 3
    if holes is not None and holes.size:
        keep[holes] = False
    if keep.all() and (counts == 3).all():
        return np.arange(3 * n_faces, dtype=np.int64).reshape(n_faces, 3), np.arange(n_faces, dtype=np.int64)
    offsets = np.cumsum(counts) - counts
    ntri = np.where(keep, counts - 2, 0)
    tri_face = np.repeat(np.arange(n_faces, dtype=np.int64), ntri)
    first = np.cumsum(ntri) - ntri
    k = np.arange(tri_face.size, dtype=np.int64) - first[tri_face]
    base = offsets[tri_face]
    tri_corner = np.stack([base, base + k + 1, base + k + 2], axis=1)
    big = keep & (counts >= 4)
    if big.any():
        for f in np.flatnonzero(_concave_faces(counts, offsets, face_vertex_indices, points, big)):
            n, o = int(counts[f]), int(offsets[f])
            poly = points[face_vertex_indices[o : o + n]].astype(np.float64)
            tri_corner[first[f] : first[f] + n - 2] = o + _ear_clip(poly)
    return tri_corner, tri_face


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the first axis of (3, M) component arrays (contiguous rows,
    several times faster than ``np.cross`` on (M, 3))."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _concave_faces(
    counts: np.ndarray, offsets: np.ndarray, fvi: np.ndarray, points: np.ndarray, candidates: np.ndarray
) -> np.ndarray:
    """Boolean (F,): polygons among ``candidates`` with a reflex corner, measured
    against the polygon's Newell normal (only the candidates' corners are visited)."""
    cand = np.flatnonzero(candidates)
    n = counts[cand]
    first = np.cumsum(n) - n  # where each candidate's corners start in the compact arrays
    local_face = np.repeat(np.arange(cand.size), n)
    start = np.repeat(offsets[cand], n)
    size = np.repeat(n, n)
    k = np.arange(local_face.size) - np.repeat(first, n)
    xyz = np.ascontiguousarray(points.T, dtype=np.float64)  # (3, N)

    def corner_points(shift: int) -> np.ndarray:
        return np.take(xyz, np.take(fvi, start + (k + shift) % size), axis=1)

    p, p_next, p_prev = corner_points(0), corner_points(1), corner_points(-1)
    normal = np.add.reduceat(_cross(p, p_next), first, axis=1)
    turn = _cross(p - p_prev, p_next - p)
    corner_normal = np.take(normal, local_face, axis=1)
    dot = (turn * corner_normal).sum(axis=0)
    scale = np.sqrt((turn * turn).sum(axis=0) * (corner_normal * corner_normal).sum(axis=0))
    reflex = (dot < -1e-9 * scale).astype(np.uint8)
    concave = np.zeros(counts.size, dtype=bool)
    concave[cand] = np.maximum.reduceat(reflex, first) > 0
    return concave


def _ear_clip(poly: np.ndarray) -> np.ndarray:
    """Ear-clip one planar-ish polygon (n, 3); returns (n-2, 3) local corner indices
    with the polygon's winding.  Falls back to a fan when no ear is found
    (self-intersecting input)."""
    n = len(poly)
    normal = np.cross(poly, np.roll(poly, -1, axis=0)).sum(axis=0)
    axis = int(np.argmax(np.abs(normal)))
    u, v = [(1, 2), (2, 0), (0, 1)][axis]
    p2 = poly[:, [u, v]].copy()
    if normal[axis] < 0:  # (u, v) is right-handed around +axis; mirror v so the polygon is CCW in 2D
        p2[:, 1] *= -1.0

    def cross(a: int, b: int, c: int) -> float:
        ab, ac = p2[b] - p2[a], p2[c] - p2[a]
        return float(ab[0] * ac[1] - ab[1] * ac[0])

    ring = list(range(n))
    tris: list[tuple[int, int, int]] = []
    while len(ring) > 3:
        m = len(ring)
        for a in range(m):
            i0, i1, i2 = ring[a - 1], ring[a], ring[(a + 1) % m]
            if cross(i0, i1, i2) <= 0.0:
                continue
            if any(
                cross(i0, i1, j) >= 0.0 and cross(i1, i2, j) >= 0.0 and cross(i2, i0, j) >= 0.0
                for j in ring
                if j not in (i0, i1, i2)
            ):
                continue
            tris.append((i0, i1, i2))
            ring.pop(a)
            break
        else:
            break
    tris.extend((ring[0], ring[k], ring[k + 1]) for k in range(1, len(ring) - 1))
    return np.asarray(tris, dtype=np.int64)


# -- normals and primvars ------------------------------------------------------------------


def vertex_normals(points: np.ndarray, tri_points: np.ndarray) -> np.ndarray:
    """Smooth, area-weighted, unit vertex normals (N, 3) of counter-clockwise triangles."""
    fn = _face_cross(points, tri_points)
    flat = tri_points.reshape(-1)
    weights = np.repeat(fn, 3, axis=0)
    vn = np.stack([np.bincount(flat, weights=weights[:, a], minlength=len(points)) for a in range(3)], axis=1)
    return _normalised(vn).astype(np.float32)


def _normalised(v: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(length > 0, length, 1.0)


def _face_cross(points: np.ndarray, tri_points: np.ndarray) -> np.ndarray:
    """(T, 3) cross products of the triangle edges: twice the area times the normal."""
    xyz = np.ascontiguousarray(points.T, dtype=np.float64)
    a, b, c = (np.take(xyz, tri_points[:, i], axis=1) for i in range(3))
    return _cross(b - a, c - a).T


def _face_normals(points: np.ndarray, tri_points: np.ndarray) -> np.ndarray:
    return _normalised(_face_cross(points, tri_points))


def _fix_normals(corner: np.ndarray, points: np.ndarray, tri_points: np.ndarray) -> np.ndarray:
    """Unit-length corner normals; zero or non-finite ones become the face normal."""
    corner = np.asarray(corner, dtype=np.float32)
    squared = np.einsum("...i,...i->...", corner, corner)
    if (np.abs(squared - 1.0) < 1e-5).all():  # already unit (the common case); NaN fails this test
        return corner
    corner = corner.astype(np.float64)
    length = np.sqrt(np.einsum("...i,...i->...", corner, corner))
    bad = ~(length > 1e-20)  # also catches NaN
    out = corner / np.where(bad, 1.0, length)[..., None]
    if bad.any():
        fn = _face_normals(points, tri_points)
        fn[np.linalg.norm(fn, axis=1) == 0] = (0.0, 0.0, 1.0)
        out = np.where(bad[..., None], fn[:, None, :], out)
    return out.astype(np.float32)


@dataclass
class _Topology:
    faces: int
    points: int
    face_vertices: int
    tri_corner: np.ndarray
    tri_points: np.ndarray
    tri_face: np.ndarray
    refinement: Refinement | None = None


def _to_corners(values: np.ndarray, interpolation: str, topo: _Topology) -> np.ndarray:
    """Expand primvar ``values`` (M, k) with ``interpolation`` to triangle corners
    (T, 3, k), through the refinement of a subdivided mesh.  ``np.take`` gathers rows
    several times faster than fancy indexing."""
    t = topo.tri_points.shape[0]
    r = topo.refinement
    if r is not None and interpolation in ("vertex", "varying", "faceVarying"):
        refined = {"vertex": r.vertex_values, "varying": r.varying_values, "faceVarying": r.face_varying_values}
        values = refined[interpolation](values).astype(values.dtype)
    if interpolation == "constant":
        return np.broadcast_to(values[0], (t, 3, values.shape[1])).copy()
    if interpolation == "uniform":
        return np.repeat(np.take(values, topo.tri_face, axis=0)[:, None, :], 3, axis=1)
    if interpolation in ("vertex", "varying"):
        return np.take(values, topo.tri_points, axis=0)
    return np.take(values, topo.tri_corner, axis=0)


def _read_primvar(
    primvar: UsdGeom.Primvar,
    interpolation: str,
    time: Usd.TimeCode,
    topo: _Topology,
    width: int,
    diag: Diagnostics,
    prim: str,
    fallback: str,
    finite_required: bool = False,
) -> np.ndarray | None:
    """A primvar's values at triangle corners (T, 3, width), or None (warned) when its
    values, indices or element count do not fit the mesh.  NaN/Inf values fall back
    too, unless ``finite_required`` (normals): then they raise ``SceneError`` naming
    the file and the prim."""
    name = primvar.GetPrimvarName() if isinstance(primvar, UsdGeom.Primvar) else primvar.GetName()
    raw = primvar.Get(time)
    if raw is None:
        return None
    values = np.asarray(raw, dtype=np.float32)
    if values.ndim != 2 or values.shape[1] != width:
        diag.warn(f"{name} has element shape {values.shape[1:]}, expected ({width},); using {fallback}", prim)
        return None
    if isinstance(primvar, UsdGeom.Primvar) and primvar.IsIndexed():
        idx = np.asarray(primvar.GetIndices(time), dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= len(values)):
            diag.warn(f"{name} indices reach outside its {len(values)} values; using {fallback}", prim)
            return None
        values = np.take(values, idx, axis=0)
    if not check_primvar(
        name, interpolation, len(values), topo.faces, topo.points, topo.face_vertices, diag, prim, fallback
    ):
        return None
    if not np.isfinite(values).all():
        bad = int(np.flatnonzero(~np.isfinite(values).all(axis=1))[0])
        if finite_required:
            raise SceneError(diag.path, f"{name} value {bad} is not finite ({values[bad].tolist()})", prim)
        diag.warn(f"{name} holds NaN/Inf values; using {fallback}", prim)
        return None
    return _to_corners(values, interpolation, topo)


def _authored_normals(
    prim: Usd.Prim, authored: frozenset[str], time: Usd.TimeCode, topo: _Topology, diag: Diagnostics, name: str
) -> np.ndarray | None:
    """Corner normals from ``primvars:normals``, else ``normals``, else None."""
    if "primvars:normals" in authored:
        pv = UsdGeom.Primvar(prim.GetAttribute("primvars:normals"))
        if pv.HasAuthoredValue():
            return _read_primvar(pv, pv.GetInterpolation(), time, topo, 3, diag, name, "computed normals", True)
    if "normals" in authored:
        attr = prim.GetAttribute("normals")
        if attr.HasAuthoredValue():
            interpolation = UsdGeom.Mesh(prim).GetNormalsInterpolation()
            return _read_primvar(attr, interpolation, time, topo, 3, diag, name, "computed normals", True)
    return None


# -- reading -------------------------------------------------------------------------------------


def _array(attr: Usd.Attribute, time: Usd.TimeCode, dtype: type, shape: tuple[int, ...]) -> np.ndarray:
    value = attr.Get(time)
    if value is None:
        return np.zeros((0,) + shape[1:], dtype=dtype)
    return np.asarray(value, dtype=dtype).reshape(shape)


def read_local_mesh(
    prim: Usd.Prim,
    time: float,
    path: str,
    diag: Diagnostics,
    may_animate: bool = True,
    points: np.ndarray | None = None,
    points_vary: bool = False,
    subdivision_levels: int | LevelChooser = DEFAULT_LEVELS,
) -> LocalMesh:
    """Read and triangulate the mesh ``prim`` at ``time`` in its local space.

    ``may_animate=False`` (the stage holds no time samples) skips the per-attribute
    time-variability queries.  ``points`` (N, 3), when given, replace the authored
    ones (skinned points; ``points_vary``: they may change over time); normals are
    then computed.  A mesh that authors a subdivision scheme is refined
    ``subdivision_levels`` times (``subdivision``; 0: its control cage; a
    ``LevelChooser``: the levels it gives for the control points and faces).  Raises
    ``SceneError`` (naming ``path`` and the prim) for NaN/Inf points, counts that do not
    sum to the index count, or indices outside the points; warns and falls back for
    degenerate faces, bad hole indices, ill-sized normals and bad crease data.
    """
    t = Usd.TimeCode(time)
    name = str(prim.GetPath())
    # Only attributes with opinions are read; the rest take their schema fallbacks
    # (no holes, rightHanded, single-sided), which saves pxr calls on big scenes.
    authored = frozenset(prim.GetAuthoredPropertyNames())
    deformed = points is not None
    if points is None:
        points = _array(prim.GetAttribute("points"), t, np.float32, (-1, 3))
    points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    counts = _array(prim.GetAttribute("faceVertexCounts"), t, np.int64, (-1,))
    fvi = _array(prim.GetAttribute("faceVertexIndices"), t, np.int64, (-1,))
    check_points(points, path, name)
    try:
        check_topology(counts, fvi, len(points), path, name)
    except SceneError as exc:
        raise MalformedMeshError(path, exc.problem, name) from None
    degenerate = int((counts < 3).sum()) if counts.size and counts.min() < 3 else 0
    if degenerate:
        diag.warn(f"{degenerate} faces have fewer than 3 vertices; skipped", name)
    holes = None
    if "holeIndices" in authored:
        holes = _array(prim.GetAttribute("holeIndices"), t, np.int64, (-1,))
        if holes.size and (holes.min() < 0 or holes.max() >= counts.size):
            diag.warn(f"holeIndices reach outside the {counts.size} faces; those entries are ignored", name)
            holes = holes[(holes >= 0) & (holes < counts.size)]
    control_points = len(points)
    levels = subdivision_levels
    if callable(levels):  # asked only for a mesh that authors a scheme
        levels = functools.partial(levels, points, counts, fvi)
    refinement = read_refinement(prim, t, authored, counts, fvi, control_points, diag, levels)
    drawn_counts, drawn_fvi = counts, fvi
    if refinement is not None:
        points = refinement.vertex_values(points).astype(np.float32)
        drawn_counts, drawn_fvi, holes = refinement.counts, refinement.indices, refinement.refined_holes(holes)
    tri_corner, tri_face = triangulate(drawn_counts, drawn_fvi, points, holes)
    if "orientation" in authored and prim.GetAttribute("orientation").Get(t) == UsdGeom.Tokens.leftHanded:
        tri_corner = tri_corner[:, [0, 2, 1]]
    tri_points = np.take(drawn_fvi, tri_corner).astype(np.int32)
    normals = None
    if refinement is not None:
        if refinement.sharp_edges.size:  # else the smooth vertex normals below
            normals = crease_normals(points, refinement, tri_corner, _face_cross(points, tri_points), tri_face)
        tri_face = refinement.face_parent[tri_face]
    topo = _Topology(int(counts.size), control_points, int(fvi.size), tri_corner, tri_points, tri_face, refinement)
    if normals is None and not deformed and refinement is None:
        normals = _authored_normals(prim, authored, t, topo, diag, name)
    if normals is None:
        normals = np.take(vertex_normals(points, tri_points), tri_points, axis=0)
    normals = _fix_normals(normals, points, tri_points)
    file_varies = may_animate and any(
        prim.GetAttribute(a).ValueMightBeTimeVarying()
        for a in (
            "points",
            "faceVertexCounts",
            "faceVertexIndices",
            "holeIndices",
            "normals",
            "primvars:normals",
            "primvars:normals:indices",
            "creaseIndices",
            "creaseLengths",
            "creaseSharpnesses",
            "cornerIndices",
            "cornerSharpnesses",
        )
        if a in authored
    )
    varying = points_vary or file_varies

    double_sided = "doubleSided" in authored and bool(prim.GetAttribute("doubleSided").Get(t))
    return LocalMesh(
        prim_path=name,
        points=points,
        tri_corner=tri_corner,
        tri_points=tri_points,
        tri_face=tri_face,
        corner_normals=normals,
        face_count=int(counts.size),
        face_vertex_count=int(fvi.size),
        double_sided=double_sided,
        time_varying=bool(varying),
        authored=authored,
        refinement=refinement,
    )


def _uv_primvar(prim: Usd.Prim, varname: str, authored: frozenset[str]) -> UsdGeom.Primvar | None:
    for name in (varname, "st"):
        if f"primvars:{name}" in authored:
            pv = UsdGeom.Primvar(prim.GetAttribute(f"primvars:{name}"))
            if pv.HasAuthoredValue():
                return pv
    if not any(a.startswith("primvars:") for a in authored):
        return None
    for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvarsWithAuthoredValues():
        if pv.GetTypeName() in _UV_TYPES:
            return pv
    return None


def corner_uvs(
    local: LocalMesh, prim: Usd.Prim, varname: str, time: float, diag: Diagnostics, needed: bool
) -> np.ndarray:
    """Texture coordinates (T, 3, 2) at the triangle corners of ``local``, read from
    the primvar ``varname``, else ``st``, else the first 2-component texcoord primvar;
    zeros when there is none (a warning when ``needed``: a textured material)."""
    if varname in local.uvs:
        return local.uvs[varname]
    name = str(prim.GetPath())
    pv = _uv_primvar(prim, varname, local.authored)
    uvs = None
    if pv is not None:
        if pv.GetPrimvarName() != varname and needed:
            diag.warn(
                f"primvar {varname!r} (read by its material's textures) is missing; reading {pv.GetPrimvarName()!r}",
                name,
            )
        uvs = corner_primvar(local, pv, time, 2, diag, "uv (0, 0)")
    elif needed:
        diag.warn(f"mesh has no uv primvar ({varname!r}) but its material is textured; uv = (0, 0)", name)
    if uvs is None:
        uvs = np.zeros((local.triangle_count, 3, 2), dtype=np.float32)
    uvs = uvs.astype(np.float32)
    local.uvs[varname] = uvs
    return uvs


def corner_primvar(
    local: LocalMesh, primvar: UsdGeom.Primvar, time: float, width: int, diag: Diagnostics, fallback: str
) -> np.ndarray | None:
    """``primvar`` of ``local``'s prim at its triangle corners (T, 3, ``width``), with
    any interpolation, indexed or not; None (warned, naming ``fallback``) when its
    values do not fit the mesh."""
    r = local.refinement
    topo = _Topology(
        local.face_count,
        len(local.points) if r is None else r.control_points,
        local.face_vertex_count,
        local.tri_corner,
        local.tri_points,
        local.tri_face,
        r,
    )
    interpolation = primvar.GetInterpolation()
    return _read_primvar(primvar, interpolation, Usd.TimeCode(time), topo, width, diag, local.prim_path, fallback)


# -- world space ---------------------------------------------------------------------------------


@dataclass
class WorldMesh:
    """A mesh (or a batch of K instances of it) in world space.

    ``points`` (K*N, 3), float64 when a matrix placed them (the loader takes them into
    its local frame before rounding to float32, ``scene.local_frame``), the local
    float32 points under an identity matrix; ``tri_points`` (K*T, 3) index into
    ``points``; corner normals/uvs (K*T, 3, k).  ``instances`` is K.  ``corner_colors``
    (K*T, 3, 3): the per-corner colours a vertex-coloured material reads, or None.
    """

    points: np.ndarray
    tri_points: np.ndarray
    corner_normals: np.ndarray
    corner_uvs: np.ndarray
    instances: int
    corner_colors: np.ndarray | None = None


def to_world(local: LocalMesh, uvs: np.ndarray, matrices: np.ndarray, colors: np.ndarray | None = None) -> WorldMesh:
    """Place ``local`` with each of ``matrices`` (K, 4, 4) USD row-vector
    local-to-world transforms (``p_world = [p, 1] @ M``); per-corner ``colors``
    (T, 3, 3), when given, follow the corners as the uvs do.

    Points use the matrix, normals its inverse transpose; a mirroring matrix
    (negative determinant) flips the winding so triangles stay counter-clockwise
    seen from the side their normals face.
    """
    k = matrices.shape[0]
    n, t = len(local.points), local.triangle_count
    if k == 1 and np.array_equal(matrices[0], np.eye(4)):
        return WorldMesh(local.points, local.tri_points, local.corner_normals, uvs, 1, colors)
    m3 = matrices[:, :3, :3]
    pts = np.einsum("nj,kji->kni", local.points.astype(np.float64), m3) + matrices[:, None, 3, :3]
    det = np.linalg.det(m3)
    safe = np.where(np.abs(det)[:, None, None] > 1e-300, m3, np.eye(3))
    normal_m = np.transpose(np.linalg.inv(safe), (0, 2, 1))
    nrm = np.einsum("tcj,kji->ktci", local.corner_normals.astype(np.float64), normal_m)
    nrm = _normalised(nrm)
    tri = np.broadcast_to(local.tri_points, (k, t, 3)) + (np.arange(k, dtype=np.int64) * n)[:, None, None]
    uv = np.broadcast_to(uvs, (k, t, 3, 2))
    col = None if colors is None else np.broadcast_to(colors, (k, t, 3, 3))
    flip = det < 0
    if flip.any():
        perm = [0, 2, 1]
        tri = np.where(flip[:, None, None], tri[:, :, perm], tri)
        nrm = np.where(flip[:, None, None, None], nrm[:, :, perm], nrm)
        uv = np.where(flip[:, None, None, None], uv[:, :, perm], uv)
        if col is not None:
            col = np.where(flip[:, None, None, None], col[:, :, perm], col)
    return WorldMesh(
        points=pts.reshape(-1, 3),
        tri_points=tri.reshape(-1, 3).astype(np.int32),
        corner_normals=nrm.reshape(-1, 3, 3).astype(np.float32),
        corner_uvs=np.ascontiguousarray(uv.reshape(-1, 3, 2), dtype=np.float32),
        instances=k,
        corner_colors=None if col is None else np.ascontiguousarray(col.reshape(-1, 3, 3), dtype=np.float32),
    )
