"""Helpers for the tracer tests: rasterize a G-buffer, trace a pixel list."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.features import SceneFeatures
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer
from warp_hybrid.scene.authoring.builders import MeshInput, look_at_camera, make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Camera, Light, LightKind, Material, Scene
from warp_hybrid.timing import StageTimer
from warp_hybrid.trace import RayCounts, Tracer, TraceSettings

# Every feature on: the variant that can render any scene (one compile for many tests).
ALL_FEATURES = SceneFeatures.all()


@dataclass
class Traced:
    """What one ``trace`` call produced, on the host."""

    color: np.ndarray
    visibility: np.ndarray
    triangle_id: np.ndarray
    position: np.ndarray
    counts: RayCounts
    stages_ms: dict[str, float]
    tracer: Tracer


def trace_scene(
    scene: Scene,
    camera: Camera,
    device: str,
    width: int = 96,
    height: int = 72,
    pixels: np.ndarray | None = None,
    settings: TraceSettings | None = None,
    features: SceneFeatures | None = None,
    threads: int = 1,
) -> Traced:
    """Rasterize ``scene`` and trace ``pixels`` (default: all) with a fresh tracer,
    compiled for ``features`` (default: the scene's own minimal variant)."""
    ds = DeviceScene(scene, device)
    cam = make_camera_gpu(camera, width, height)
    gb = GBuffer(width, height, device)
    lights = max(len(scene.lights), 1)
    listed = np.arange(width * height, dtype=np.int32) if pixels is None else np.asarray(pixels, np.int32)
    with Launcher(device, threads=threads) as launcher:
        Rasterizer(launcher).render(ds, cam, gb, StageTimer())
        tracer = Tracer(launcher, settings or TraceSettings(), features)
        color = wp.zeros((height, width), dtype=wp.vec3, device=device)
        vis = wp.full((height, width, lights), value=float("nan"), dtype=wp.float32, device=device)
        timer = StageTimer()
        counts = tracer.trace(
            ds, cam, gb, wp.array(listed, dtype=wp.int32, device=device), len(listed), color, vis, timer
        ).counts()
    return Traced(
        color.numpy(), vis.numpy(), gb.triangle_id.numpy(), gb.position.numpy(), counts, timer.stages_ms, tracer
    )


def trace_variants(scene: Scene, camera: Camera, device: str, *args, **kwargs) -> Traced:
    """``trace_scene`` twice, with the scene's minimal tracer variant and with every
    feature compiled in; asserts both give the same image and visibility (code a scene
    does not need must not change its result) and returns the minimal variant's run."""
    minimal = trace_scene(scene, camera, device, *args, **kwargs)
    everything = trace_scene(scene, camera, device, *args, features=ALL_FEATURES, **kwargs)
    np.testing.assert_array_equal(minimal.color, everything.color)
    np.testing.assert_array_equal(minimal.visibility, everything.visibility)
    assert minimal.counts == everything.counts
    return minimal


def camera_rays(camera: Camera, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """float64 origin (3,) and unit directions (H, W, 3) through the pixel centres
    (the ``CameraGPU`` convention)."""
    m = np.asarray(camera.cam_to_world, dtype=np.float64)
    right, up, forward = m[:3, 0], m[:3, 1], -m[:3, 2]
    tan_x = camera.tan_half_fov_x
    tan_y = camera.tan_half_fov_y(width, height)
    cols, rows = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    ndc_x = 2.0 * cols / width - 1.0
    ndc_y = 1.0 - 2.0 * rows / height
    d = forward + (ndc_x * tan_x)[..., None] * right + (ndc_y * tan_y)[..., None] * up
    return m[:3, 3].copy(), d / np.linalg.norm(d, axis=-1, keepdims=True)


def box(
    center: tuple[float, float, float], half: tuple[float, float, float], rotation_y_deg: float = 0.0, material: int = 0
) -> MeshInput:
    """A closed box (12 outward-facing triangles, flat normals), rotated about +Y."""
    c = np.asarray(center, dtype=np.float64)
    hx, hy, hz = half
    corners = np.array([[x, y, z] for x in (-hx, hx) for y in (-hy, hy) for z in (-hz, hz)], dtype=np.float64)
    a = np.radians(rotation_y_deg)
    rot = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    pts = corners @ rot.T + c
    # corner index = 4 ix + 2 iy + iz
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    idx = []
    for q in faces:
        idx += [(q[0], q[1], q[2]), (q[0], q[2], q[3])]
    mesh = MeshInput(pts.astype(np.float32), np.asarray(idx, np.int32), material)
    centroid = pts[np.asarray(idx)].mean(axis=1)
    normals = np.cross(
        pts[np.asarray(idx)[:, 1]] - pts[np.asarray(idx)[:, 0]], pts[np.asarray(idx)[:, 2]] - pts[np.asarray(idx)[:, 0]]
    )
    assert np.all(np.einsum("ij,ij->i", normals, centroid - c) > 0), "box faces must face outward"
    return mesh


def emissive(name: str, color: tuple[float, float, float]) -> Material:
    """A black, rough, light-emitting material (its radiance is ``color``)."""
    return Material(name, diffuse=(0.0, 0.0, 0.0), emissive=color, roughness=1.0)


def grid_quad(corner, edge_u, edge_v, n: int, material: int) -> MeshInput:
    """A parallelogram split into n x n cells (2 n^2 triangles), facing edge_u x edge_v."""
    c, u, v = (np.asarray(a, dtype=np.float64) for a in (corner, edge_u, edge_v))
    s, t = np.meshgrid(np.linspace(0.0, 1.0, n + 1), np.linspace(0.0, 1.0, n + 1))
    pts = c + s[..., None] * u + t[..., None] * v
    idx = []
    for r in range(n):
        for k in range(n):
            a, b = r * (n + 1) + k, r * (n + 1) + k + 1
            idx += [(a, b, b + n + 1), (a, b + n + 1, a + n + 1)]
    return MeshInput(pts.reshape(-1, 3).astype(np.float32), np.asarray(idx, np.int32), material)


def pane_scene(opacity: float, thin: bool = True, blended: bool = False, panes: int = 1) -> tuple[Scene, Camera]:
    """A red pane (y = 1, thin-walled, 8 x 8 cells; glass, or alpha-blended coverage
    when ``blended``) between a light straight above and a white floor; with ``panes`` 2
    a second one of the same material above it (y = 1.6, shifted 0.7 along x), so rays
    toward the light cross both where they overlap."""
    pane = Material(
        "/pane", diffuse=(0.9, 0.1, 0.08), roughness=0.0, opacity=opacity, thin_walled=thin, alpha_blended=blended
    )
    mats = [Material("/floor", diffuse=(0.8, 0.8, 0.8), roughness=0.9), pane]
    meshes = [
        quad((-3.0, 0.0, 3.0), (6.0, 0.0, 0.0), (0.0, 0.0, -6.0), 0),
        grid_quad((-1.0, 1.0, 1.0), (2.0, 0.0, 0.0), (0.0, 0.0, -2.0), 8, 1),
    ]
    if panes == 2:
        meshes.append(grid_quad((-0.3, 1.6, 1.0), (2.0, 0.0, 0.0), (0.0, 0.0, -2.0), 8, 1))
    light = Light(LightKind.DISTANT, "/sun", (2.0, 2.0, 2.0), direction=(0.0, -1.0, 0.0))
    cam = look_at_camera((0.0, 5.0, 6.0), (0.0, 0.0, 0.0))
    return make_scene(meshes, mats, lights=[light], cameras=[cam]), cam
