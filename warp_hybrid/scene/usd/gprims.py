"""What the loader draws: a ``UsdGeom.Mesh`` or an implicit prim, read into a ``LocalMesh``.

``read_gprim`` is the one dispatch between ``meshes.read_local_mesh`` (polygon meshes)
and ``implicit.read_implicit_mesh`` (Cube, Sphere, Cone, Cylinder, Capsule, Plane);
``is_drawn`` says which prims it takes.  ``empty_mesh`` stands in for a mesh skipped
as malformed (``meshes.MalformedMeshError``), so the rest of the stage still draws.
"""

from __future__ import annotations

import numpy as np
from pxr import Usd, UsdGeom

from .implicit import is_implicit, read_implicit_mesh
from .meshes import LocalMesh, read_local_mesh
from .subdivision import DEFAULT_LEVELS
from .subdivision_level import LevelChooser
from .validate import Diagnostics


def is_drawn(prim: Usd.Prim) -> bool:
    """True for the gprims the loader tessellates: meshes and implicit shapes."""
    return prim.IsA(UsdGeom.Mesh) or is_implicit(prim)


def read_gprim(
    prim: Usd.Prim,
    time: float,
    path: str,
    diag: Diagnostics,
    may_animate: bool = True,
    points: np.ndarray | None = None,
    points_vary: bool = False,
    subdivision_levels: int | LevelChooser = DEFAULT_LEVELS,
) -> LocalMesh:
    """``prim`` (``is_drawn``) triangulated in its local space at ``time``.  For a mesh,
    ``points``, ``points_vary`` and ``subdivision_levels`` go to ``read_local_mesh``
    (skinned points, subdivision), and what it raises propagates
    (``MalformedMeshError`` for bad topology); implicit prims take neither."""
    if prim.IsA(UsdGeom.Mesh):
        return read_local_mesh(prim, time, path, diag, may_animate, points, points_vary, subdivision_levels)
    return read_implicit_mesh(prim, time, may_animate)


def empty_mesh(prim: Usd.Prim) -> LocalMesh:
    """A mesh with no points and no triangles for ``prim`` (drawn as nothing)."""
    return LocalMesh(
        prim_path=str(prim.GetPath()),
        points=np.zeros((0, 3), dtype=np.float32),
        tri_corner=np.zeros((0, 3), dtype=np.int64),
        tri_points=np.zeros((0, 3), dtype=np.int32),
        tri_face=np.zeros((0,), dtype=np.int64),
        corner_normals=np.zeros((0, 3, 3), dtype=np.float32),
        face_count=0,
        face_vertex_count=0,
        double_sided=False,
        time_varying=False,
    )
