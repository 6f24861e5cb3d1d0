"""The path kernel's primary direct light across a group of items (``primary_light.primary_direct``)
against the point-by-point sum ``shade_hit`` computed before it: every light kind, a rect light
above, across and below the points' horizons, glass and paint, a pixel list in no order with
entries outside the image, both diffuse-colour rules."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from shading_kit import gbuffer_under_rect, light_set

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.pixel_list import listed_pixel
from warp_hybrid.core.scene_gpu import FLAG_TRANSMISSIVE, SceneGPU
from warp_hybrid.lighting.lights import light_sample
from warp_hybrid.lighting.shading import diffuse_albedo, light_response
from warp_hybrid.parallel import ITEM_GROUP
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Material
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


@pytest.mark.parametrize("max_depth", [0, 4])
@pytest.mark.parametrize("transparency", [False, True])
def test_group_sum_matches_the_point_sum(device, max_depth, transparency):
    rng = np.random.default_rng(11)
    materials = [Material("paint", roughness=0.4), Material("glass", opacity=0.3, ior=1.5)]
    scene = make_scene([quad((-3, -1, -3), (6, 0, 0), (0, 0, 6))], materials, lights=light_set("all"))
    ds = DeviceScene(scene, device)
    gb = gbuffer_under_rect(device, rng, W, H)
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
