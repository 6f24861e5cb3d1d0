"""The path kernel's primary dome terms across a group of items (``primary_dome.primary_dome``)
against the scalar ``ambient_diffuse`` and ``ambient_specular`` ``shade_hit`` calls: no dome (the
lights' indirect estimate alone), a constant and a textured one (the glossy lobe on the dome's
own texture, between mip levels and past the last), glass and paint, a pixel list in no order
with entries outside the image and background pixels, which lanes carry the glossy term."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from shading_kit import dome_arguments, gbuffer_under_rect, light_set

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.constants import GLOSSY_ROUGHNESS
from warp_hybrid.core.pixel_list import listed_pixel
from warp_hybrid.core.scene_gpu import FLAG_TRANSMISSIVE, AmbientGPU, SceneGPU
from warp_hybrid.lighting.ambient import ambient_diffuse, ambient_specular
from warp_hybrid.parallel import ITEM_GROUP
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Material
from warp_hybrid.trace.occluders import OccluderGPU
from warp_hybrid.trace.primary_dome import DIFFUSE, GLOSSY, HAS_GLOSSY, ROW_FLOATS, primary_dome
from warp_hybrid.trace.rays import TraceFrame, TraceParams

wp.set_module_options({"enable_backward": False})

H, W = 8, 40


@wp.kernel
def group_kernel(
    scene: SceneGPU,
    amb: AmbientGPU,
    tf: TraceFrame,
    stop: int,
    transparency: bool,
    glossy: bool,
    out: wp.array2d(dtype=wp.float32),
):
    first = wp.tid() * ITEM_GROUP
    last = wp.min(first + ITEM_GROUP, stop)
    rows = primary_dome(scene, amb, tf, first, last, transparency, glossy)
    for item in range(first, last):
        for k in range(ROW_FLOATS):
            out[item, k] = rows[item - first, k]


@wp.kernel
def point_kernel(
    scene: SceneGPU, amb: AmbientGPU, tf: TraceFrame, transparency: bool, out: wp.array2d(dtype=wp.float32)
):
    """``shade_hit``'s dome terms at segment 0 as it computed them: one point at a time."""
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
    f0 = tf.gb.specular[y, x]
    kd = albedo
    if transparency and (scene.materials[tf.gb.material_id[y, x]].flags & FLAG_TRANSMISSIVE) != 0:
        kd = albedo * opt.opacity
    diffuse = ambient_diffuse(scene, amb, n, v, kd, f0)
    glossy = ambient_specular(scene, amb, n, v, f0, opt.roughness)
    for k in range(3):
        out[item, DIFFUSE + k] = diffuse[k]
        out[item, GLOSSY + k] = glossy[k]


@pytest.mark.parametrize("dome", ["none", "constant", "textured"])
@pytest.mark.parametrize("transparency", [False, True])
def test_group_dome_terms_match_the_scalar_lookups(device, dome, transparency):
    rng = np.random.default_rng(13)
    materials = [Material("paint"), Material("glass", opacity=0.3, ior=1.5)]
    scene = make_scene(
        [quad((-3, -1, -3), (6, 0, 0), (0, 0, 6))], materials, lights=light_set("all"), **dome_arguments(dome, rng)
    )
    ds = DeviceScene(scene, device, indirect=dome == "none")
    gb = gbuffer_under_rect(device, rng, W, H)
    optics = gb.optics.numpy()
    roughness = optics["roughness"]
    roughness[:, ::5] = 0.0  # a mirror: no glossy lane
    roughness[:, 1::5] = GLOSSY_ROUGHNESS  # the last roughness without one
    roughness[:, 2::5] = 0.3  # between mip levels
    roughness[:, 3::5] = 1.0  # past the last level: blended into the SH irradiance
    gb.optics.assign(optics)
    triangles = np.zeros((H, W), np.int32)
    triangles[:, 7::9] = -1  # background pixels among the hits
    gb.triangle_id.assign(triangles)
    listed = rng.permutation(H * W).astype(np.int32)
    listed[[5, 37, 100]] = (-1, H * W, H * W + 7)
    count = len(listed)
    tf = TraceFrame()
    tf.cam = make_camera_gpu(look_at_camera((0.5, 3.0, 4.0), (0.0, 0.0, 0.0)), W, H)
    tf.params = TraceParams()
    tf.params.max_depth = 3
    tf.occ = OccluderGPU()
    tf.gb = gb.kernel_arrays()
    tf.pixels = wp.array(listed, dtype=wp.int32, device=device)
    got = wp.zeros((count, ROW_FLOATS), dtype=wp.float32, device=device)
    want = wp.zeros((count, ROW_FLOATS), dtype=wp.float32, device=device)
    groups = -(-count // ITEM_GROUP)
    inputs = [ds.gpu, ds.ambient, tf]
    wp.launch(group_kernel, dim=groups, inputs=[*inputs, count, transparency, True, got], device=device)
    wp.launch(point_kernel, dim=count, inputs=[*inputs, transparency, want], device=device)
    inside = (listed >= 0) & (listed < H * W)
    hits = np.zeros(count, bool)
    hits[inside] = triangles.ravel()[listed[inside]] >= 0
    got, want = got.numpy()[hits], want.numpy()[hits]
    rough = roughness.ravel()[listed[hits]]
    np.testing.assert_array_equal(got[:, HAS_GLOSSY], (rough > GLOSSY_ROUGHNESS).astype(np.float32))
    diffuse, specular = slice(DIFFUSE, DIFFUSE + 3), slice(GLOSSY, GLOSSY + 3)
    assert np.all(np.isfinite(want)) and want[:, diffuse].max() > 0.01
    glossy = got[:, HAS_GLOSSY] == 1.0
    if dome == "none":
        assert not want[:, specular].any()
    else:
        assert want[glossy, specular].max() > 0.01
    if dome == "textured":
        assert ds.ambient.levels == 3 and ds.ambient.sh_bands == 3
        assert np.ptp(want[glossy, specular], axis=0).min() > 0.01  # the glossy term reads the texture
    if device == "cpu":
        # the same lambdas, vectorised or not: the same bits
        np.testing.assert_array_equal(got[:, diffuse], want[:, diffuse])
        np.testing.assert_array_equal(got[glossy, specular], want[glossy, specular])
    else:
        np.testing.assert_allclose(got[:, diffuse], want[:, diffuse], rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(got[glossy, specular], want[glossy, specular], rtol=1e-6, atol=1e-7)
    # without the glossy term (a variant with no dome lookups) no lane carries it
    plain = wp.zeros((count, ROW_FLOATS), dtype=wp.float32, device=device)
    wp.launch(group_kernel, dim=groups, inputs=[*inputs, count, transparency, False, plain], device=device)
    assert not plain.numpy()[:, HAS_GLOSSY].any()
