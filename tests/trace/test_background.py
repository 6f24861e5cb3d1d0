"""The path kernel's background across a group of items (``background.group_background``)
against the scalar lookup ``begin_item`` made before it, ``environment_radiance`` along
``pixel_ray_direction``: no dome, a constant and a textured one, a jittered sample point, a
pixel list in no order with entries outside the image, groups with no background pixel."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from shading_kit import dome_arguments, gbuffer_under_rect

from warp_hybrid.core.camera import make_camera_gpu, pixel_ray_direction
from warp_hybrid.core.pixel_list import listed_pixel
from warp_hybrid.core.scene_gpu import SceneGPU
from warp_hybrid.parallel import ITEM_GROUP
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.device.environment import environment_radiance
from warp_hybrid.scene.model import Material
from warp_hybrid.trace.background import group_background
from warp_hybrid.trace.occluders import OccluderGPU
from warp_hybrid.trace.rays import TraceFrame, TraceParams

wp.set_module_options({"enable_backward": False})

H, W = 12, 40


@wp.kernel
def group_kernel(scene: SceneGPU, tf: TraceFrame, stop: int, out: wp.array(dtype=wp.vec3)):
    first = wp.tid() * ITEM_GROUP
    last = wp.min(first + ITEM_GROUP, stop)
    rows = group_background(scene, tf, first, last)
    for item in range(first, last):
        out[item] = rows[item - first]


@wp.kernel
def point_kernel(scene: SceneGPU, tf: TraceFrame, out: wp.array(dtype=wp.vec3)):
    """``begin_item``'s background as it was: one pixel at a time."""
    item = wp.tid()
    xy = listed_pixel(tf.pixels, item, tf.cam.width, tf.cam.height)
    if xy[0] < 0:
        return
    out[item] = environment_radiance(scene, pixel_ray_direction(tf.cam, xy[0], xy[1]))


@pytest.mark.parametrize("dome", ["none", "constant", "textured"])
def test_group_background_matches_the_scalar_lookup(device, dome):
    rng = np.random.default_rng(5)
    scene = make_scene([quad((-3, -1, -3), (6, 0, 0), (0, 0, 6))], [Material("paint")], **dome_arguments(dome, rng))
    ds = DeviceScene(scene, device)
    gb = gbuffer_under_rect(device, rng, W, H)
    triangles = np.zeros((H, W), np.int32)
    triangles[H // 2 :] = np.where(rng.uniform(size=(H - H // 2, W)) < 0.6, -1, 0)  # background in the lower half
    gb.triangle_id.assign(triangles)
    # the upper half in order first (whole groups with no background pixel), then the rest
    # in no order, with entries outside the image (their rows are not read)
    upper = H // 2 * W
    listed = np.concatenate([np.arange(upper), upper + rng.permutation(H * W - upper)]).astype(np.int32)
    listed[[upper + 3, upper + 50, len(listed) - 1]] = (-1, H * W, H * W + 7)
    count = len(listed)
    tf = TraceFrame()
    # a jittered sample point, as a supersampled frame's
    tf.cam = make_camera_gpu(look_at_camera((0.5, 0.3, 4.0), (0.0, 0.8, 0.0)), W, H, sample=(0.25, 0.75))
    tf.params = TraceParams()
    tf.occ = OccluderGPU()
    tf.gb = gb.kernel_arrays()
    tf.pixels = wp.array(listed, dtype=wp.int32, device=device)
    got = wp.zeros(count, dtype=wp.vec3, device=device)
    want = wp.zeros(count, dtype=wp.vec3, device=device)
    wp.launch(group_kernel, dim=-(-count // ITEM_GROUP), inputs=[ds.gpu, tf, count, got], device=device)
    wp.launch(point_kernel, dim=count, inputs=[ds.gpu, tf, want], device=device)
    inside = (listed >= 0) & (listed < H * W)
    background = np.zeros(count, bool)
    background[inside] = triangles.ravel()[listed[inside]] < 0
    assert background.sum() > 100
    got, want = got.numpy()[background], want.numpy()[background]
    if dome == "none":
        assert not want.any()
    elif dome == "constant":
        np.testing.assert_array_equal(want, np.broadcast_to(np.float32([0.2, 0.3, 0.4]), want.shape))
    else:
        assert np.ptp(want, axis=0).min() > 0.05  # the background reads the texture
    if device == "cpu":
        np.testing.assert_array_equal(got, want)  # the same lambdas, vectorised or not: the same bits
    else:
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)
