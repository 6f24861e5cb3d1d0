"""The deferred pass's native row loop of direct light against the scalar functions, pixel by pixel."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.camera import CameraGPU, make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer, GBufferArrays
from warp_hybrid.core.scene_gpu import SceneGPU
from warp_hybrid.lighting.direct_rows import direct_span
from warp_hybrid.lighting.shading import diffuse_albedo, direct_light
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Environment, Light, LightKind, Material

wp.set_module_options({"enable_backward": False})

#: 70 columns: one whole chunk of 64 pixels and a tail of 6.
H, W = 4, 70
RECT_CENTRE = (0.0, 2.0, 0.0)


@wp.kernel
def rows_kernel(
    scene: SceneGPU, cam: CameraGPU, gb: GBufferArrays, begin: int, end: int, out: wp.array2d(dtype=wp.vec3)
):
    y = wp.tid()
    direct_span(scene, cam, gb, out, begin, end, y, 0, cam.width)


@wp.kernel
def scalar_kernel(scene: SceneGPU, cam: CameraGPU, gb: GBufferArrays, out: wp.array2d(dtype=wp.vec3)):
    y, x = wp.tid()
    p = gb.position[y, x]
    n = gb.normal[y, x]
    v = wp.normalize(cam.origin - p)
    opt = gb.optics[y, x]
    flags = scene.materials[gb.material_id[y, x]].flags
    kd = diffuse_albedo(scene, n, v, gb.albedo[y, x], opt.opacity, opt.ior, flags)
    direct = wp.vec3(0.0, 0.0, 0.0)
    for i in range(scene.light_count):
        direct += direct_light(scene, i, p, n, v, kd, gb.specular[y, x], opt.roughness)
    out[y, x] = direct


def _lights(kind: str) -> list[Light]:
    """One light of ``kind`` ("rect": a rectangle facing down over the points; "all": one
    of every kind, a spot among them)."""
    rect = Light(
        LightKind.RECT,
        "rect",
        (3.0, 2.5, 2.0),
        position=RECT_CENTRE,
        direction=(0.0, -1.0, 0.0),
        axis_u=(0.5, 0.0, 0.0),
        axis_v=(0.0, 0.0, 0.4),
    )
    if kind == "rect":
        return [rect]
    return [
        rect,
        Light(LightKind.DISTANT, "sun", (1.0, 0.9, 0.8), direction=(0.3, -1.0, 0.2)),
        Light(LightKind.SPHERE, "bulb", (5.0, 5.0, 5.0), position=(1.0, 1.5, 1.0), radius=0.2, normalize=True),
        Light(LightKind.SPHERE, "point", (2.0, 1.0, 1.0), position=(-1.0, 1.0, 0.5)),
        Light(
            LightKind.SPHERE,
            "spot",
            (8.0, 8.0, 8.0),
            position=(0.0, 3.0, 1.0),
            direction=(0.0, -1.0, 0.0),
            radius=0.1,
            cone_angle_deg=30.0,
            cone_softness=0.5,
        ),
        Light(
            LightKind.DISK,
            "disk",
            (4.0, 4.0, 4.0),
            position=(-1.5, 2.0, -1.0),
            direction=(0.2, -1.0, 0.0),
            radius=0.3,
        ),
    ]


def _gbuffer(device: str, rng: np.random.Generator) -> GBuffer:
    """Points below the rect light; row 0 faces it (the rectangle above every horizon),
    row 1 faces sideways under it (the horizon cuts it at every pixel), rows 2 and 3 have
    random normals (a mix); random colours, roughness 0.15-1, every third pixel glass."""
    gb = GBuffer(W, H, device)
    pos = np.zeros((H, W, 3), np.float32)
    pos[..., 0] = rng.uniform(-2.0, 2.0, (H, W))
    pos[1, :, 0] = rng.uniform(-0.3, 0.3, W)
    pos[..., 1] = rng.uniform(-0.2, 0.2, (H, W))
    pos[..., 2] = rng.uniform(-0.3, 0.3, (H, W))
    normal = rng.normal(size=(H, W, 3)).astype(np.float32)
    normal[0] = (0.0, 1.0, 0.0)
    normal[1] = (1.0, 0.0, 0.0)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    gb.position.assign(pos)
    gb.normal.assign(normal)
    gb.albedo.assign(rng.uniform(0.0, 1.0, (H, W, 3)).astype(np.float32))
    gb.specular.assign(rng.uniform(0.0, 1.0, (H, W, 3)).astype(np.float32))
    optics = np.zeros((H, W), dtype=gb.optics.numpy().dtype)
    optics["roughness"] = rng.uniform(0.15, 1.0, (H, W))
    optics["opacity"] = rng.uniform(0.0, 1.0, (H, W))
    optics["ior"] = rng.uniform(1.2, 2.0, (H, W))
    gb.optics.assign(optics)
    gb.material_id.assign((np.arange(H * W).reshape(H, W) % 3 == 0).astype(np.int32))
    gb.triangle_id.assign(np.zeros((H, W), np.int32))
    return gb


@pytest.mark.parametrize("lights", ["rect", "all"])
@pytest.mark.parametrize("dome", [False, True])
def test_row_loop_matches_the_scalar_sum(device, lights, dome):
    rng = np.random.default_rng(7)
    materials = [Material("paint"), Material("glass", opacity=0.3, ior=1.5)]
    env = Environment("dome", (0.2, 0.3, 0.4)) if dome else None
    scene = make_scene([quad((-3, -1, -3), (6, 0, 0), (0, 0, 6))], materials, lights=_lights(lights), environment=env)
    ds = DeviceScene(scene, device)
    cam = make_camera_gpu(look_at_camera((0.5, 3.0, 4.0), (0.0, 0.0, 0.0)), W, H)
    gb = _gbuffer(device, rng)
    got = wp.zeros((H, W), dtype=wp.vec3, device=device)
    want = wp.zeros((H, W), dtype=wp.vec3, device=device)
    count = len(scene.lights)
    wp.launch(rows_kernel, dim=H, inputs=[ds.gpu, cam, gb.kernel_arrays(), 0, count, got], device=device)
    wp.launch(scalar_kernel, dim=(H, W), inputs=[ds.gpu, cam, gb.kernel_arrays(), want], device=device)
    got, want = got.numpy(), want.numpy()
    assert np.all(np.isfinite(want)) and want.max() > 0.1
    # every row lit, and the rect light's three kinds of chunk all present
    assert np.all(want.sum(axis=(1, 2)) > 0.0)
    # one light at a time (the shadowed kernel's way), summed in order: the same sum
    terms = wp.zeros((H, W), dtype=wp.vec3, device=device)
    summed = np.zeros((H, W, 3), np.float32)
    for i in range(count):
        wp.launch(rows_kernel, dim=H, inputs=[ds.gpu, cam, gb.kernel_arrays(), i, i + 1, terms], device=device)
        summed = summed + terms.numpy()
    np.testing.assert_array_equal(summed, got)
    if device == "cpu":
        # the same lambdas, vectorised or not: the same bits (no FMA contraction in this module)
        np.testing.assert_array_equal(got, want)
    else:
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)
