"""The path kernel's primary direct light across a group of items (``primary_light.primary_direct``)
against the point-by-point sum ``shade_hit`` computed before it: every light kind, a rect light
above, across and below the points' horizons, glass and paint, a pixel list in no order with
entries outside the image, both diffuse-colour rules."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.core.pixel_list import listed_pixel
from warp_hybrid.core.scene_gpu import FLAG_TRANSMISSIVE, SceneGPU
from warp_hybrid.lighting.lights import light_sample
from warp_hybrid.lighting.shading import diffuse_albedo, light_response
from warp_hybrid.parallel import ITEM_GROUP
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Light, LightKind, Material
from warp_hybrid.trace.occluders import OccluderGPU
from warp_hybrid.trace.primary_light import primary_direct
from warp_hybrid.trace.rays import TraceFrame, TraceParams

wp.set_module_options({"enable_backward": False})

H, W = 6, 40


@wp.kernel
def group_kernel(scene: SceneGPU, tf: TraceFrame, stop: int, transparency: bool, out: wp.array(dtype=wp.vec3)):
    first = wp.tid() * ITEM_GROUP
    last = wp.min(first + ITEM_GROUP, stop)
    rows = primary_direct(scene, tf, first, last, transparency)
    for item in range(first, last):
        out[item] = rows[item - first]


@wp.kernel
def point_kernel(scene: SceneGPU, tf: TraceFrame, transparency: bool, out: wp.array(dtype=wp.vec3)):
    """``shade_hit``'s sum at segment 0 as it was: one point, one light at a time."""
    item = wp.tid()
    xy = listed_pixel(tf.pixels, item, tf.cam.width, tf.cam.height)
    if xy[0] < 0:
        return
    x = xy[0]
    y = xy[1]
    p = tf.gb.position[y, x]
    n = tf.gb.normal[y, x]
    v = -wp.normalize(p - tf.cam.origin)
    albedo = tf.gb.albedo[y, x]
    opt = tf.gb.optics[y, x]
    flags = scene.materials[tf.gb.material_id[y, x]].flags
    kd = albedo
    if tf.params.max_depth > 0:
        if transparency and (flags & FLAG_TRANSMISSIVE) != 0:
            kd = albedo * opt.opacity
    else:
        kd = diffuse_albedo(scene, n, v, albedo, opt.opacity, opt.ior, flags)
    direct = wp.vec3(0.0, 0.0, 0.0)
    for i in range(scene.light_count):
        c = light_response(light_sample(scene.lights[i], p, n), n, v, kd, tf.gb.specular[y, x], opt.roughness)
        direct += wp.cw_mul(c, tf.transmittance[item, i])
    out[item] = direct


def _lights() -> list[Light]:
    """One light of every kind (a spot among them), a rect light facing down over the points."""
    return [
        Light(
            LightKind.RECT,
            "rect",
            (3.0, 2.5, 2.0),
            position=(0.0, 2.0, 0.0),
            direction=(0.0, -1.0, 0.0),
            axis_u=(0.5, 0.0, 0.0),
            axis_v=(0.0, 0.0, 0.4),
        ),
        Light(LightKind.DISTANT, "sun", (1.0, 0.9, 0.8), direction=(0.3, -1.0, 0.2)),
        Light(LightKind.SPHERE, "bulb", (5.0, 5.0, 5.0), position=(1.0, 1.5, 1.0), radius=0.2, normalize=True),
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
            LightKind.DISK, "disk", (4.0, 4.0, 4.0), position=(-1.5, 2.0, -1.0), direction=(0.2, -1.0, 0.0), radius=0.3
        ),
    ]


def _gbuffer(device: str, rng: np.random.Generator) -> GBuffer:
    """Points under the rect light: row 0 faces it, row 1 faces sideways (its horizon cuts
    the rectangle), the other rows random normals; random colours, every third pixel glass."""
    gb = GBuffer(W, H, device)
    pos = np.stack(
        [rng.uniform(-2.0, 2.0, (H, W)), rng.uniform(-0.2, 0.2, (H, W)), rng.uniform(-0.3, 0.3, (H, W))], axis=-1
    )
    normal = rng.normal(size=(H, W, 3))
    normal[0] = (0.0, 1.0, 0.0)
    normal[1] = (1.0, 0.0, 0.0)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    gb.position.assign(pos.astype(np.float32))
    gb.normal.assign(normal.astype(np.float32))
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


@pytest.mark.parametrize("max_depth", [0, 4])
@pytest.mark.parametrize("transparency", [False, True])
def test_group_sum_matches_the_point_sum(device, max_depth, transparency):
    rng = np.random.default_rng(11)
    materials = [Material("paint", roughness=0.4), Material("glass", opacity=0.3, ior=1.5)]
    scene = make_scene([quad((-3, -1, -3), (6, 0, 0), (0, 0, 6))], materials, lights=_lights())
    ds = DeviceScene(scene, device)
    gb = _gbuffer(device, rng)
    # every pixel once in no order, and entries outside the image (their rows are not read)
    listed = rng.permutation(H * W).astype(np.int32)
    listed[[5, 37, 100]] = (-1, H * W, H * W + 7)
    count = len(listed)
    lights = len(scene.lights)
    tf = TraceFrame()
    tf.cam = make_camera_gpu(look_at_camera((0.5, 3.0, 4.0), (0.0, 0.0, 0.0)), W, H)
    tf.params = TraceParams()
    tf.params.max_depth = max_depth
    tf.occ = OccluderGPU()
    tf.gb = gb.kernel_arrays()
    tf.pixels = wp.array(listed, dtype=wp.int32, device=device)
    # transmittances from 0 (blocked) to 1, coloured
    shade = rng.uniform(0.0, 1.0, (count, lights, 3)).astype(np.float32)
    shade[rng.uniform(size=(count, lights)) < 0.2] = 0.0
    tf.transmittance = wp.array(shade, dtype=wp.vec3, device=device)
    tf.counts = wp.zeros((count, 4), dtype=wp.int32, device=device)
    got = wp.zeros(count, dtype=wp.vec3, device=device)
    want = wp.zeros(count, dtype=wp.vec3, device=device)
    groups = -(-count // ITEM_GROUP)
    wp.launch(group_kernel, dim=groups, inputs=[ds.gpu, tf, count, transparency, got], device=device)
    wp.launch(point_kernel, dim=count, inputs=[ds.gpu, tf, transparency, want], device=device)
    inside = (listed >= 0) & (listed < H * W)
    got, want = got.numpy()[inside], want.numpy()[inside]
    assert np.all(np.isfinite(want)) and want.max() > 0.1
    assert np.count_nonzero(want.max(axis=1) == 0.0) < len(want) // 2
    if device == "cpu":
        np.testing.assert_array_equal(got, want)  # the same lambdas, vectorised or not: the same bits
    else:
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)
