"""The path kernel's dome lookups across a group of items (``background.group_background``,
``first_ray_sky``) against the scalar ones they replace (``environment_radiance`` along
``pixel_ray_direction`` and along an escaping ray): no dome, a constant and a textured one,
a jittered sample point, a pixel list in no order with entries outside the image, groups
with no background pixel or no missed ray."""

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
from warp_hybrid.trace.background import GroupDirections, GroupFlags, GroupHits, first_ray_sky, group_background
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


@wp.kernel
def sky_group_kernel(
    scene: SceneGPU,
    directions: wp.array2d(dtype=wp.float32),
    hits: wp.array(dtype=wp.float32),
    queried: wp.array(dtype=wp.int32),
    out: wp.array(dtype=wp.vec3),
):
    first = wp.tid() * ITEM_GROUP
    d = GroupDirections()
    h = GroupHits()
    q = GroupFlags()
    for k in range(ITEM_GROUP):
        for c in range(3):
            d[k, c] = directions[first + k, c]
        h[k, 7] = hits[first + k]
        q[k] = queried[first + k]
    rows = first_ray_sky(scene, d, h, q)
    for k in range(ITEM_GROUP):
        out[first + k] = rows[k]


@wp.kernel
def sky_point_kernel(scene: SceneGPU, directions: wp.array2d(dtype=wp.float32), out: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    out[i] = environment_radiance(scene, wp.vec3(directions[i, 0], directions[i, 1], directions[i, 2]))


@pytest.mark.parametrize("dome", ["none", "constant", "textured"])
def test_first_ray_sky_matches_the_scalar_lookup(device, dome):
    """The dome along first rays the packet query found to miss, across a group, against
    ``finish_item``'s lookup one ray at a time: unit directions everywhere on the sphere,
    rays that hit, lanes with no ray, groups where no ray misses."""
    rng = np.random.default_rng(9)
    scene = make_scene([quad((-3, -1, -3), (6, 0, 0), (0, 0, 6))], [Material("paint")], **dome_arguments(dome, rng))
    ds = DeviceScene(scene, device)
    count = 8 * ITEM_GROUP
    d = rng.normal(size=(count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hit = (rng.uniform(size=count) < 0.4).astype(np.float32)
    queried = (rng.uniform(size=count) < 0.8).astype(np.int32)
    hit[:ITEM_GROUP] = 1.0  # a group where every ray hits
    directions = wp.array(d.astype(np.float32), dtype=wp.float32, device=device)
    got = wp.zeros(count, dtype=wp.vec3, device=device)
    want = wp.zeros(count, dtype=wp.vec3, device=device)
    args = [wp.array(hit, dtype=wp.float32, device=device), wp.array(queried, dtype=wp.int32, device=device)]
    wp.launch(sky_group_kernel, dim=count // ITEM_GROUP, inputs=[ds.gpu, directions, *args, got], device=device)
    wp.launch(sky_point_kernel, dim=count, inputs=[ds.gpu, directions, want], device=device)
    missed = (queried != 0) & (hit == 0.0)
    assert missed.sum() > 40
    got, want = got.numpy()[missed], want.numpy()[missed]
    if dome == "none":
        assert not want.any()
    elif dome == "textured":
        assert np.ptp(want, axis=0).min() > 0.05
    if device == "cpu":
        np.testing.assert_array_equal(got, want)
    else:
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)
