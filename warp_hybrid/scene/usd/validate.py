"""Checks on scene data: per-prim checks while a USD mesh is read, and a final check
on the flattened ``Scene`` arrays, plus the warning log every loader module shares.

Hard errors (the data cannot be rendered correctly) raise ``SceneError`` naming the
file and the prim: NaN/Inf points, ``faceVertexCounts`` that do not sum to the number
of ``faceVertexIndices``, negative counts, out-of-range face indices.  Recoverable
problems (polygons with fewer than three vertices, primvars whose element count does
not match their interpolation, bad primvar indices) become warnings and a fallback.

Warnings go through ``logging`` (logger ``warp_hybrid.scene``) and are collected in
``Diagnostics.messages`` (copied into ``Scene.warnings``); each distinct warning is
emitted once per scene source, however many frames or instances hit it.
"""

from __future__ import annotations

import logging

import numpy as np

from ...errors import SceneError
from ..local_frame import frame_problem
from ..model import Scene

LOG = logging.getLogger("warp_hybrid.scene")


class Diagnostics:
    """Collects warnings for one scene source and logs each distinct one once."""

    def __init__(self, path: str) -> None:
        """``path`` is the scene file every message is about."""
        self.path = str(path)
        self.messages: list[str] = []
        self._seen: set[str] = set()

    def warn(self, message: str, prim: str | None = None, key: str | None = None) -> None:
        """Record ``message`` about ``prim`` unless the same ``key`` (default: the full
        message) was already reported."""
        text = f"{prim}: {message}" if prim else message
        k = key if key is not None else text
        if k in self._seen:
            return
        self._seen.add(k)
        self.messages.append(text)
        LOG.warning("%s: %s", self.path, text)


def check_points(points: np.ndarray, path: str, prim: str) -> None:
    """Raise ``SceneError`` when any point is NaN or infinite."""
    finite = np.isfinite(points)
    if not finite.all():
        bad = int(np.flatnonzero(~finite.all(axis=-1))[0])
        raise SceneError(path, f"point {bad} is not finite ({points[bad].tolist()})", prim)


def check_topology(counts: np.ndarray, indices: np.ndarray, point_count: int, path: str, prim: str) -> None:
    """Raise ``SceneError`` for negative face counts, counts that do not sum to the
    number of face-vertex indices, or indices outside ``[0, point_count)``."""
    if counts.size and counts.min() < 0:
        raise SceneError(path, f"faceVertexCounts holds a negative count ({int(counts.min())})", prim)
    total = int(counts.sum())
    if total != indices.size:
        raise SceneError(
            path, f"faceVertexCounts sum to {total} but faceVertexIndices has {indices.size} entries", prim
        )
    if indices.size:
        lo, hi = int(indices.min()), int(indices.max())
        if lo < 0 or hi >= point_count:
            bad = lo if lo < 0 else hi
            raise SceneError(
                path,
                f"faceVertexIndices holds {bad}, outside the {point_count} points (valid 0..{point_count - 1})",
                prim,
            )


def expected_primvar_count(interpolation: str, faces: int, points: int, face_vertices: int) -> int | None:
    """How many elements a mesh primvar with ``interpolation`` must have (None: unknown
    interpolation)."""
    return {
        "constant": 1,
        "uniform": faces,
        "vertex": points,
        "varying": points,
        "faceVarying": face_vertices,
    }.get(interpolation)


def check_primvar(
    name: str,
    interpolation: str,
    count: int,
    faces: int,
    points: int,
    face_vertices: int,
    diag: Diagnostics,
    prim: str,
    fallback: str,
) -> bool:
    """True when a primvar with ``count`` elements fits its interpolation; otherwise
    warn (naming the fallback used) and return False."""
    expected = expected_primvar_count(interpolation, faces, points, face_vertices)
    if expected is None:
        diag.warn(f"{name} has unknown interpolation {interpolation!r}; using {fallback}", prim)
        return False
    if count != expected:
        diag.warn(
            f"{name} has {count} values but {interpolation} interpolation needs {expected}; using {fallback}", prim
        )
        return False
    return True


def check_extent(scene: Scene) -> None:
    """Raise ``SceneError`` naming the file and the prim (the mesh of the point, the
    camera or the light) when ``scene`` is beyond the representable range
    (``scene.local_frame.frame_problem``)."""
    found = frame_problem(scene.points, scene.cameras, scene.lights, np.asarray(scene.origin, dtype=np.float64))
    if found is None:
        return
    problem, at = found
    prim = (
        at
        if isinstance(at, str)
        else next((r.prim_path for r in scene.meshes if r.first_point <= at < r.first_point + r.point_count), None)
    )
    raise SceneError(scene.path, problem, prim)


def validate_scene(scene: Scene) -> None:
    """Check the flattened arrays of ``scene`` (shapes, dtypes, finiteness, index and
    material ranges) and raise ``SceneError`` naming the file and the mesh prim at fault.

    The loaders guarantee these already; this is the last gate before data reaches a
    kernel, so a bug or a hand-built ``Scene`` never turns into an out-of-bounds read.
    Last, the scene must lie within the representable range (``check_extent``).
    """
    path = scene.path
    n, t = len(scene.points), scene.triangle_count
    shapes = {
        "points": (scene.points, (n, 3), np.float32),
        "indices": (scene.indices, (t, 3), np.int32),
        "corner_normals": (scene.corner_normals, (t, 3, 3), np.float32),
        "corner_uvs": (scene.corner_uvs, (t, 3, 2), np.float32),
        "triangle_material": (scene.triangle_material, (t,), np.int32),
    }
    for name, (arr, shape, dtype) in shapes.items():
        if arr.shape != shape or arr.dtype != dtype:
            raise SceneError(path, f"{name} has shape {arr.shape} {arr.dtype}, expected {shape} {np.dtype(dtype)}")

    def prim_of_triangle(tri: int) -> str | None:
        for r in scene.meshes:
            if r.first_triangle <= tri < r.first_triangle + r.triangle_count:
                return r.prim_path
        return None

    def prim_of_point(pt: int) -> str | None:
        for r in scene.meshes:
            if r.first_point <= pt < r.first_point + r.point_count:
                return r.prim_path
        return None

    bad_pts = ~np.isfinite(scene.points).all(axis=1)
    if bad_pts.any():
        i = int(np.flatnonzero(bad_pts)[0])
        raise SceneError(path, f"point {i} is not finite", prim_of_point(i))
    if t:
        bad_idx = ((scene.indices < 0) | (scene.indices >= n)).any(axis=1)
        if bad_idx.any():
            i = int(np.flatnonzero(bad_idx)[0])
            raise SceneError(path, f"triangle {i} indexes outside the {n} points", prim_of_triangle(i))
        for name in ("corner_normals", "corner_uvs"):
            bad = ~np.isfinite(getattr(scene, name)).reshape(t, -1).all(axis=1)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise SceneError(path, f"{name} of triangle {i} are not finite", prim_of_triangle(i))
        m = scene.triangle_material
        bad_m = (m < 0) | (m >= len(scene.materials))
        if bad_m.any():
            i = int(np.flatnonzero(bad_m)[0])
            raise SceneError(
                path, f"triangle {i} uses material {int(m[i])} of {len(scene.materials)}", prim_of_triangle(i)
            )
    check_extent(scene)
