"""UsdGeom implicit prims (Cube, Sphere, Cone, Cylinder, Capsule, Plane) -> ``LocalMesh``.

The shape parameters are read through each schema's own attributes, so authored values
and the schema fallbacks come from pxr (``size``; ``radius``; ``height``; ``axis``;
``radiusTop``/``radiusBottom`` of ``Cylinder_1`` and ``Capsule_1``; ``width``/``length``
of ``Plane``; ``doubleSided``, whose fallback is true for ``Plane``).  The geometry
follows the schemas: centred at the origin, the spine along ``axis``, a cone's apex and
a ``*_1`` shape's ``radiusTop`` at +height/2; a capsule's ``height`` excludes its two
hemispherical caps.

Tessellation density (fixed, independent of screen size): every round shape is cut
into ``SEGMENTS`` = 48 slices around its spine (7.5 degrees); a sphere has ``RINGS`` = 24
latitude bands (7.5 degrees), each capsule cap 12; straight sides are one band; a cube
is 12 triangles, a plane 2.  All vertices lie on the exact surface, so the mesh lies
inside it by at most ``R (1 - cos^2(3.75 deg))`` = 0.43% of the radius (at a patch
centre).  Normals are the exact surface normals at the vertices (smooth on round
surfaces, flat on caps and cube faces).  The triangles are counter-clockwise seen
from outside.

A tessellated prim has no faces in USD's sense, so its ``LocalMesh`` lists every
triangle as its own face: only constant primvars (``displayColor``) map onto it.
"""

from __future__ import annotations

import math

import numpy as np
from pxr import Usd, UsdGeom

from .meshes import LocalMesh

SEGMENTS = 48
RINGS = 24
CAP_RINGS = RINGS // 2

IMPLICIT_TYPES = (
    UsdGeom.Cube,
    UsdGeom.Sphere,
    UsdGeom.Cone,
    UsdGeom.Cylinder,
    UsdGeom.Cylinder_1,
    UsdGeom.Capsule,
    UsdGeom.Capsule_1,
    UsdGeom.Plane,
)
_PARAMETERS = ("size", "radius", "height", "axis", "radiusTop", "radiusBottom", "width", "length", "doubleSided")

# (u, v, w) world axes for a spine along X, Y or Z: cyclic, so u x v = w (right-handed).
_BASES = {
    "X": np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0]], dtype=np.float64),
    "Y": np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], dtype=np.float64),
    "Z": np.eye(3, dtype=np.float64),
}

# A profile piece: (r, z, normal_r, normal_z) rows, walked with the outside on the
# right so that revolving it counter-clockwise about the spine faces outward.
Profile = np.ndarray


def is_implicit(prim: Usd.Prim) -> bool:
    """True for the implicit gprims this module tessellates."""
    return any(prim.IsA(t) for t in IMPLICIT_TYPES)


def _get(prim: Usd.Prim, name: str, time: Usd.TimeCode) -> object:
    """An attribute's value at ``time``: the authored one or the schema fallback."""
    return prim.GetAttribute(name).Get(time)


def _arc(radius: float, centre: float, theta0: float, theta1: float, steps: int) -> Profile:
    """A circular profile arc from polar angle ``theta0`` to ``theta1`` (0 = -spine pole)."""
    theta = np.linspace(theta0, theta1, steps + 1)
    s, c = np.sin(theta), -np.cos(theta)
    s[np.abs(s) < 1e-12] = 0.0  # the poles lie on the spine exactly (sin(pi) is not 0)
    return np.stack([radius * s, centre + radius * c, s, c], axis=1)


def _segment(r0: float, z0: float, r1: float, z1: float) -> Profile:
    """A straight profile piece from (r0, z0) to (r1, z1) with its outward normal."""
    dr, dz = r1 - r0, z1 - z0
    length = math.hypot(dr, dz) or 1.0
    nr, nz = dz / length, -dr / length
    return np.array([[r0, z0, nr, nz], [r1, z1, nr, nz]], dtype=np.float64)


def _revolve(pieces: list[Profile], basis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Revolve profile pieces about the spine ``basis[2]``: points (N, 3), triangles
    (T, 3) and per-point normals (N, 3).  Quads that touch the spine become triangles."""
    phi = np.linspace(0.0, 2.0 * math.pi, SEGMENTS + 1)
    cos_phi, sin_phi = np.cos(phi), np.sin(phi)
    points, normals, tris = [], [], []
    base = 0
    for piece in pieces:
        r, z, nr, nz = piece.T
        radial = cos_phi[None, :, None] * basis[0] + sin_phi[None, :, None] * basis[1]  # (1, S+1, 3)
        pts = r[:, None, None] * radial + z[:, None, None] * basis[2]
        nrm = nr[:, None, None] * radial + nz[:, None, None] * basis[2]
        points.append(pts.reshape(-1, 3))
        normals.append(nrm.reshape(-1, 3))
        ring = SEGMENTS + 1
        for i in range(len(piece) - 1):
            j = np.arange(SEGMENTS)
            a = base + i * ring + j
            b, c, d = a + 1, a + ring + 1, a + ring
            if r[i] > 0.0:
                tris.append(np.stack([a, b, c], axis=1))
            if r[i + 1] > 0.0:
                tris.append(np.stack([a, c, d], axis=1))
        base += len(piece) * ring
    return np.concatenate(points), np.concatenate(tris), np.concatenate(normals)


def _box(size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A cube of edge ``size`` centred at the origin: 6 faces of 2 triangles."""
    h = 0.5 * size
    points, normals, tris = [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            u = np.zeros(3)
            u[(axis + 1) % 3] = 1.0
            v = np.cross(n, u)
            k = len(points)
            points.extend(h * (n + su * u + sv * v) for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)))
            normals.extend([n] * 4)
            tris.extend([(k, k + 1, k + 2), (k, k + 2, k + 3)])
    return np.array(points), np.array(tris), np.array(normals)


def _plane(width: float, length: float, axis: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """UsdGeomPlane: normal along ``axis``; width along X (Z when the axis is X),
    length along Y (Z when the axis is Y)."""
    eye = np.eye(3)
    w_dir = eye[2] if axis == "X" else eye[0]
    l_dir = eye[2] if axis == "Y" else eye[1]
    n = eye["XYZ".index(axis)]
    corners = [0.5 * (su * width * w_dir + sv * length * l_dir) for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    tris = [(0, 1, 2), (0, 2, 3)]
    if np.dot(np.cross(w_dir, l_dir), n) < 0:
        tris = [(0, 2, 1), (0, 3, 2)]
    return np.array(corners), np.array(tris), np.array([n] * 4)


def _shape(prim: Usd.Prim, t: Usd.TimeCode) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, triangles and point normals of the implicit ``prim`` at ``t``."""
    if prim.IsA(UsdGeom.Cube):
        return _box(float(_get(prim, "size", t)))
    if prim.IsA(UsdGeom.Plane):
        return _plane(float(_get(prim, "width", t)), float(_get(prim, "length", t)), str(_get(prim, "axis", t)))
    if prim.IsA(UsdGeom.Sphere):
        return _revolve([_arc(float(_get(prim, "radius", t)), 0.0, 0.0, math.pi, RINGS)], _BASES["Z"])
    basis = _BASES.get(str(_get(prim, "axis", t)), _BASES["Z"])
    h = 0.5 * float(_get(prim, "height", t))
    if prim.IsA(UsdGeom.Cylinder_1) or prim.IsA(UsdGeom.Capsule_1):
        top, bottom = float(_get(prim, "radiusTop", t)), float(_get(prim, "radiusBottom", t))
    else:
        top = bottom = float(_get(prim, "radius", t))
    if prim.IsA(UsdGeom.Cone):
        top = 0.0
    if prim.IsA(UsdGeom.Capsule) or prim.IsA(UsdGeom.Capsule_1):
        pieces = [
            _arc(bottom, -h, 0.0, 0.5 * math.pi, CAP_RINGS),
            _segment(bottom, -h, top, h),
            _arc(top, h, 0.5 * math.pi, math.pi, CAP_RINGS),
        ]
    else:
        pieces = [_segment(0.0, -h, bottom, -h), _segment(bottom, -h, top, h)]
        if top > 0.0:
            pieces.append(_segment(top, h, 0.0, h))
    return _revolve(pieces, basis)


def read_implicit_mesh(prim: Usd.Prim, time: float, may_animate: bool = True) -> LocalMesh:
    """Tessellate the implicit ``prim`` (``is_implicit``) at ``time`` in its local space
    (see the module docstring for the density); ``may_animate=False`` skips the
    time-variability queries."""
    t = Usd.TimeCode(time)
    authored = frozenset(prim.GetAuthoredPropertyNames())
    varying = may_animate and any(prim.GetAttribute(a).ValueMightBeTimeVarying() for a in _PARAMETERS if a in authored)
    double_sided = bool(_get(prim, "doubleSided", t))
    return _local_mesh(str(prim.GetPath()), *_shape(prim, t), double_sided, bool(varying), authored)


def box_mesh(prim_path: str, lo: np.ndarray, hi: np.ndarray, time_varying: bool) -> LocalMesh:
    """The axis-aligned box from ``lo`` to ``hi`` (3,) as a single-sided ``LocalMesh`` of
    ``prim_path``, tessellated as a ``Cube`` is (12 triangles, flat face normals)."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    points, tris, point_normals = _box(1.0)
    return _local_mesh(prim_path, 0.5 * (lo + hi) + points * (hi - lo), tris, point_normals, False, time_varying)


def _local_mesh(
    prim_path: str,
    points: np.ndarray,
    tris: np.ndarray,
    point_normals: np.ndarray,
    double_sided: bool,
    time_varying: bool,
    authored: frozenset[str] = frozenset(),
) -> LocalMesh:
    """A tessellation as a ``LocalMesh`` whose every triangle is its own face."""
    tri_points = np.ascontiguousarray(tris, dtype=np.int32)
    count = len(tri_points)
    return LocalMesh(
        prim_path=prim_path,
        points=np.ascontiguousarray(points, dtype=np.float32),
        tri_corner=np.arange(3 * count, dtype=np.int64).reshape(count, 3),
        tri_points=tri_points,
        tri_face=np.arange(count, dtype=np.int64),
        corner_normals=np.take(point_normals.astype(np.float32), tri_points, axis=0),
        face_count=count,
        face_vertex_count=3 * count,
        double_sided=double_sided,
        time_varying=time_varying,
        authored=authored,
    )
