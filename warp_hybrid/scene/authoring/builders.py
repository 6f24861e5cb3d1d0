"""Build ``Scene`` objects directly from numpy: analytic test scenes, procedural
content and the library API for callers that have no USD file."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import Camera, Environment, Light, Material, MeshRange, Scene


@dataclass
class MeshInput:
    """One mesh to add: world-space ``points`` (N, 3), triangle ``indices`` (T, 3),
    optional per-vertex ``normals`` (N, 3) and ``uvs`` (N, 2), a material index."""

    points: np.ndarray
    indices: np.ndarray
    material: int = 0
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None
    name: str = "/mesh"


def face_normals(points: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Unit geometric normals (T, 3) of counter-clockwise triangles."""
    p = points[indices]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return (n / np.where(length > 0, length, 1.0)).astype(np.float32)


def vertex_normals(points: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Area-weighted smooth vertex normals (N, 3)."""
    p = points[indices]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    vn = np.zeros_like(points, dtype=np.float64)
    for k in range(3):
        np.add.at(vn, indices[:, k], fn)
    length = np.linalg.norm(vn, axis=1, keepdims=True)
    return (vn / np.where(length > 0, length, 1.0)).astype(np.float32)


def make_scene(
    meshes: list[MeshInput],
    materials: list[Material],
    lights: list[Light] | None = None,
    cameras: list[Camera] | None = None,
    environment: Environment | None = None,
    path: str = "<memory>",
    **extra: object,
) -> Scene:
    """Flatten ``meshes`` into one ``Scene`` (flat-shaded where normals are absent)."""
    points, indices, normals, uvs, tri_mat, ranges = [], [], [], [], [], []
    base = 0
    tri_base = 0
    for m in meshes:
        pts = np.asarray(m.points, dtype=np.float32).reshape(-1, 3)
        idx = np.asarray(m.indices, dtype=np.int32).reshape(-1, 3)
        if m.normals is not None:
            cn = np.asarray(m.normals, dtype=np.float32)[idx]
        else:
            cn = np.repeat(face_normals(pts, idx)[:, None, :], 3, axis=1)
        cu = np.asarray(m.uvs, dtype=np.float32)[idx] if m.uvs is not None else np.zeros((len(idx), 3, 2), np.float32)
        points.append(pts)
        indices.append(idx + base)
        normals.append(cn)
        uvs.append(cu)
        tri_mat.append(np.full(len(idx), m.material, dtype=np.int32))
        ranges.append(MeshRange(m.name, tri_base, len(idx), base, len(pts)))
        base += len(pts)
        tri_base += len(idx)
    return Scene(
        path=path,
        points=np.concatenate(points) if points else np.zeros((0, 3), np.float32),
        indices=np.concatenate(indices) if indices else np.zeros((0, 3), np.int32),
        corner_normals=np.concatenate(normals) if normals else np.zeros((0, 3, 3), np.float32),
        corner_uvs=np.concatenate(uvs) if uvs else np.zeros((0, 3, 2), np.float32),
        triangle_material=np.concatenate(tri_mat) if tri_mat else np.zeros((0,), np.int32),
        materials=materials,
        lights=lights or [],
        cameras=cameras or [],
        environment=environment,
        meshes=ranges,
        **extra,
    )


def uv_sphere(
    center: tuple[float, float, float],
    radius: float,
    rings: int = 64,
    segments: int = 128,
    material: int = 0,
    name: str = "/sphere",
) -> MeshInput:
    """A UV sphere with smooth normals and (u, v) = (longitude, latitude) in [0, 1]."""
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(p), np.cos(t), -np.sin(t) * np.sin(p)], axis=-1).reshape(-1, 3)
    uv = np.stack([p / (2 * np.pi), 1.0 - t / np.pi], axis=-1).reshape(-1, 2)
    pts = np.asarray(center, dtype=np.float64) + radius * n
    idx = []
    w = segments + 1
    for r in range(rings):
        for s in range(segments):
            a, b, c, d = r * w + s, r * w + s + 1, (r + 1) * w + s, (r + 1) * w + s + 1
            if r != 0:
                idx.append((a, c, b))
            if r != rings - 1:
                idx.append((b, c, d))
    return MeshInput(
        pts.astype(np.float32), np.asarray(idx, np.int32), material, n.astype(np.float32), uv.astype(np.float32), name
    )


def quad(
    corner: tuple[float, float, float],
    edge_u: tuple[float, float, float],
    edge_v: tuple[float, float, float],
    material: int = 0,
    name: str = "/quad",
) -> MeshInput:
    """A parallelogram ``corner + s*edge_u + t*edge_v`` (s, t in [0, 1]) as two
    triangles, facing ``edge_u x edge_v``, with uv = (s, t)."""
    c, u, v = (np.asarray(a, dtype=np.float64) for a in (corner, edge_u, edge_v))
    pts = np.array([c, c + u, c + u + v, c + v], dtype=np.float32)
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
    idx = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32)
    return MeshInput(pts, idx, material, None, uvs, name)


def look_at_camera(
    eye: tuple[float, float, float],
    target: tuple[float, float, float],
    up: tuple[float, float, float] = (0.0, 1.0, 0.0),
    hfov_deg: float = 60.0,
    near: float = 0.01,
    far: float = 1.0e4,
    name: str = "/camera",
) -> Camera:
    """A camera at ``eye`` looking at ``target`` with a horizontal FOV in degrees."""
    e, t, u = (np.asarray(a, dtype=np.float64) for a in (eye, target, up))
    f = t - e
    f /= np.linalg.norm(f)
    r = np.cross(f, u)
    r /= np.linalg.norm(r)
    up2 = np.cross(r, f)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = r, up2, -f, e
    focal = 50.0
    aperture = 2.0 * focal * np.tan(np.radians(hfov_deg) / 2.0)
    return Camera(name, m, focal, float(aperture), float(aperture), near, far)
