"""The deferred pass's native row loops (the lights' direct sum, and the whole radiance under a
direction-free dome) against the scalar functions, pixel by pixel."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from shading_kit import dome_arguments, gbuffer_under_rect, light_set

from warp_hybrid.core.camera import CameraGPU, make_camera_gpu, pixel_ray
from warp_hybrid.core.gbuffer import GBufferArrays
from warp_hybrid.core.scene_gpu import AmbientGPU, SceneGPU
from warp_hybrid.lighting.ambient import direction_free
from warp_hybrid.lighting.direct_rows import direct_span, lit_span
from warp_hybrid.lighting.shading import diffuse_albedo, direct_light, shade_surface
from warp_hybrid.post.kernels import LOG_LUMINANCE_KERNELS, MASK_ID
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.device.environment import environment_radiance
from warp_hybrid.scene.model import Environment, Material

wp.set_module_options({"enable_backward": False})

#: 70 columns: one whole chunk of 64 pixels and a tail of 6.
H, W = 4, 70


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


@wp.kernel
def lit_rows_kernel(
    scene: SceneGPU,
    amb: AmbientGPU,
    cam: CameraGPU,
    gb: GBufferArrays,
    out: wp.array2d(dtype=wp.vec3),
    emissive: int,
    meter: int,
    meter_sum: wp.array(dtype=wp.float64),
    meter_count: wp.array(dtype=wp.int32),
):
    y = wp.tid()
    lit_span(scene, amb, cam, gb, out, 0, scene.light_count, emissive, meter, meter_sum, meter_count, y, 0, cam.width)


@wp.kernel
def lit_scalar_kernel(
    scene: SceneGPU, amb: AmbientGPU, cam: CameraGPU, gb: GBufferArrays, out: wp.array2d(dtype=wp.vec3)
):
    y, x = wp.tid()
    if gb.triangle_id[y, x] < 0:
        out[y, x] = environment_radiance(scene, pixel_ray(cam, x, y))
        return
    p = gb.position[y, x]
    n = gb.normal[y, x]
    v = wp.normalize(cam.origin - p)
    opt = gb.optics[y, x]
    flags = scene.materials[gb.material_id[y, x]].flags
    kd = diffuse_albedo(scene, n, v, gb.albedo[y, x], opt.opacity, opt.ior, flags)
    f0 = gb.specular[y, x]
    direct = wp.vec3(0.0, 0.0, 0.0)
    for i in range(scene.light_count):
        direct += direct_light(scene, i, p, n, v, kd, f0, opt.roughness)
    out[y, x] = shade_surface(
        scene, amb, n, v, gb.albedo[y, x], kd, f0, opt.roughness, gb.emission[y, x], opt.opacity, opt.ior, flags, direct
    )


@wp.kernel
def direction_free_kernel(scene: SceneGPU, amb: AmbientGPU, out: wp.array(dtype=wp.int32)):
    out[0] = wp.where(direction_free(scene, amb), 1, 0)


@pytest.mark.parametrize("lights", ["rect", "all"])
@pytest.mark.parametrize("dome", [False, True])
def test_row_loop_matches_the_scalar_sum(device, lights, dome):
    rng = np.random.default_rng(7)
    materials = [Material("paint"), Material("glass", opacity=0.3, ior=1.5)]
    env = Environment("dome", (0.2, 0.3, 0.4)) if dome else None
    scene = make_scene([quad((-3, -1, -3), (6, 0, 0), (0, 0, 6))], materials, lights=light_set(lights), environment=env)
    ds = DeviceScene(scene, device)
    cam = make_camera_gpu(look_at_camera((0.5, 3.0, 4.0), (0.0, 0.0, 0.0)), W, H)
    gb = gbuffer_under_rect(device, rng, W, H)
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


@pytest.mark.parametrize("dome", ["none", "constant", "textured"])
@pytest.mark.parametrize("indirect", [False, True])
def test_lit_row_loop_matches_the_scalar_shading(device, dome, indirect):
    """The whole radiance under no dome, an untextured one and a textured one (with and
    without the lights' indirect estimate in the ambient irradiance): emission, every
    kind of light, the ambient diffuse and glossy terms (mirror-sharp, between mip
    levels and past the last one), light through glass, and the dome on background
    pixels, the same as ``shade_surface`` pixel by pixel; and on the CPU each row's
    log-luminance sum and count, metered as the loop writes the row, the post stage's
    (``post.kernels``' pass over the written colour with the hit mask) bit for bit."""
    rng = np.random.default_rng(11)
    materials = [Material("paint"), Material("glass", opacity=0.3, ior=1.5)]
    scene = make_scene(
        [quad((-3, -1, -3), (6, 0, 0), (0, 0, 6))], materials, lights=light_set("all"), **dome_arguments(dome, rng)
    )
    ds = DeviceScene(scene, device, indirect=indirect)
    flag = wp.zeros(1, dtype=wp.int32, device=device)
    wp.launch(direction_free_kernel, dim=1, inputs=[ds.gpu, ds.ambient, flag], device=device)
    assert flag.numpy()[0] == (0 if dome == "textured" else 1)
    cam = make_camera_gpu(look_at_camera((0.5, 3.0, 4.0), (0.0, 0.0, 0.0)), W, H)
    gb = gbuffer_under_rect(device, rng, W, H)
    optics = gb.optics.numpy()
    optics["roughness"][:, ::4] = 0.0  # the dome's own texture (mip level 0)
    optics["roughness"][:, 1::4] = 1.0  # past the last level: blended into the SH irradiance
    gb.optics.assign(optics)
    emission = np.zeros((H, W, 3), np.float32)
    emission[:, ::5] = rng.uniform(0.0, 2.0, (H, len(range(0, W, 5)), 3))
    gb.emission.assign(emission)
    triangles = np.zeros((H, W), np.int32)
    triangles[:, 7::9] = -1  # background pixels among the hits
    triangles[-1] = -1  # and a row of background alone (chunks that take no light)
    gb.triangle_id.assign(triangles)
    got = wp.zeros((H, W), dtype=wp.vec3, device=device)
    want = wp.zeros((H, W), dtype=wp.vec3, device=device)
    inputs = [ds.gpu, ds.ambient, cam, gb.kernel_arrays()]
    metered = (wp.zeros(H, dtype=wp.float64, device=device), wp.zeros(H, dtype=wp.int32, device=device))
    meter = 1 if device == "cpu" else 0  # (CUDA: a launch item a pixel, the post stage meters)
    wp.launch(lit_rows_kernel, dim=H, inputs=[*inputs, got, 1, meter, *metered], device=device)
    wp.launch(lit_scalar_kernel, dim=(H, W), inputs=[*inputs, want], device=device)
    # a scene without an emissive material (``emissive`` 0): the emission channel is not
    # read, the radiance that of a zero emission
    unlit = wp.zeros((H, W), dtype=wp.vec3, device=device)
    wp.launch(lit_rows_kernel, dim=H, inputs=[*inputs, unlit, 0, 0, *metered], device=device)
    gb.emission.zero_()
    dark = wp.zeros((H, W), dtype=wp.vec3, device=device)
    wp.launch(lit_scalar_kernel, dim=(H, W), inputs=[*inputs, dark], device=device)
    assert not np.array_equal(dark.numpy(), want.numpy())
    if device == "cpu":
        post = (wp.zeros(H, dtype=wp.float64, device=device), wp.zeros(H, dtype=wp.int32, device=device))
        log_kernel = LOG_LUMINANCE_KERNELS[MASK_ID]
        wp.launch(log_kernel, dim=(H, 1), inputs=[got, gb.triangle_id, *post, 0, 1, W], device=device)
        assert post[1].numpy()[:-1].min() > 0 and post[1].numpy()[-1] == 0  # (the background row counts none)
        np.testing.assert_array_equal(metered[0].numpy(), post[0].numpy())
        np.testing.assert_array_equal(metered[1].numpy(), post[1].numpy())
    got, want = got.numpy(), want.numpy()
    assert np.all(np.isfinite(want)) and want.max() > 0.1
    background = want[triangles < 0]
    if dome == "textured":
        assert ds.ambient.levels == 3 and ds.ambient.sh_bands == 3
        assert np.ptp(background, axis=0).min() > 0.05  # the background reads the texture
    else:
        sky = np.asarray(scene.environment.color, np.float32) if dome == "constant" else np.zeros(3, np.float32)
        np.testing.assert_array_equal(background, np.broadcast_to(sky, background.shape))
    if indirect:
        assert max(ds.ambient.indirect) > 0.0
    for rows, scalar in ((got, want), (unlit.numpy(), dark.numpy())):
        if device == "cpu":
            np.testing.assert_array_equal(rows, scalar)
        else:
            np.testing.assert_allclose(rows, scalar, rtol=1e-6, atol=1e-7)
