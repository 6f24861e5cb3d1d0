"""The surface pass's native row loop against ``surface_at_grad``, pixel by pixel: every
G-buffer channel the same bits, whichever way a chunk's materials are evaluated (over the
chunk with vectorised taps, over the chunk with the other wrap modes, lane by lane, or
left to the scalar path for a normal map)."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.camera import CameraGPU, make_camera_gpu, pixel_ray
from warp_hybrid.core.gbuffer import CHANNELS, GBuffer, GBufferRows
from warp_hybrid.core.native_rows import SURFACE_CHUNK_CPU
from warp_hybrid.core.scene_gpu import SceneGPU
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import PrimaryVisibility, Rasterizer
from warp_hybrid.primary.kernels import SHORT_RUN_PIXELS, SURFACE_ALL, _write_surface
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Material, TextureBinding, TextureImage, Wrap
from warp_hybrid.timing import StageTimer

wp.set_module_options({"enable_backward": False})

#: 150 columns: two whole chunks of 64 pixels and a tail; a row's first pixel starts a
#: cache line in every eighth row (150 x 12 bytes a row).
W, H = 150, 60


@wp.kernel
def scalar_surface_kernel(scene: SceneGPU, cam: CameraGPU, gb: GBufferRows):
    y, x = wp.tid()
    i = y * cam.width + x
    tri = gb.triangle_id[i]
    if tri >= 0:
        _write_surface(gb, i, scene, cam, tri, gb.barycentric[i], pixel_ray(cam, x, y), wp.static(SURFACE_ALL))


def _scene():
    """A floor seen at a grazing angle (its texture minified, trilinear between levels,
    repeating 12 times) and, standing on it, panels whose materials take every path: a
    clamped texture, a mirrored one with a uv transform, a specular-workflow colour, a
    textured roughness and emission (lane by lane), a normal map (the scalar path); and a
    finely cut sphere of the floor's material, whose triangles are smaller than a pixel (the
    gather lane by lane)."""
    rng = np.random.default_rng(5)
    images = [
        TextureImage(f"<img{k}>", rng.uniform(0.0, 1.0, (40 + 8 * k, 56, 4)).astype(np.float32)) for k in range(4)
    ]
    images.append(
        TextureImage(
            "<normals>",
            np.concatenate([rng.uniform(0.3, 0.7, (16, 16, 2)), np.ones((16, 16, 2))], axis=2).astype(np.float32),
        )
    )
    textures = [
        TextureBinding(0, uv_transform=(12.0, 0.0, 0.0, 0.0, 12.0, 0.0)),
        TextureBinding(1, wrap_s=Wrap.CLAMP, wrap_t=Wrap.BLACK, uv_transform=(1.5, 0.0, -0.25, 0.0, 1.5, -0.25)),
        TextureBinding(2, wrap_s=Wrap.MIRROR, wrap_t=Wrap.REPEAT, uv_transform=(0.0, 3.0, 0.1, -3.0, 0.0, 0.2)),
        TextureBinding(3),
        TextureBinding(4),
    ]
    materials = [
        Material("floor", diffuse_texture=0, metallic=0.3, roughness=0.4),
        Material("clamped", diffuse_texture=1),
        Material("mirrored", diffuse_texture=2, metallic=0.8),
        Material("given", diffuse=(0.6, 0.2, 0.1), specular=(0.3, 0.5, 0.7), use_specular_workflow=True),
        Material("lanes", diffuse_texture=3, roughness_texture=3, roughness_channel=1, emissive_texture=3),
        Material("bumps", diffuse=(0.4, 0.4, 0.4), normal_texture=4),
    ]
    meshes = [quad((-6.0, 0.0, 4.0), (12.0, 0.0, 0.0), (0.0, 0.0, -30.0), 0, "/floor")]
    for k in range(1, len(materials)):
        x = -5.0 + 2.0 * (k - 1)
        meshes.append(quad((x, 0.0, -2.0 - 0.7 * k), (1.6, 0.0, 0.3), (0.0, 2.5, 0.0), k, f"/panel{k}"))
    meshes.append(uv_sphere((3.6, 0.9, -0.5), 0.8, rings=32, segments=64, material=0, name="/fine"))
    scene = make_scene(meshes, materials, images=images, textures=textures)
    return scene, look_at_camera((0.0, 1.6, 6.0), (0.0, 0.6, -6.0), hfov_deg=70.0)


@pytest.mark.parametrize("threads", [1, 2])
def test_row_loop_writes_what_surface_at_grad_gives(device, threads):
    scene, camera = _scene()
    ds = DeviceScene(scene, device)
    cam = make_camera_gpu(camera, W, H)
    loop = GBuffer(W, H, device)
    with Launcher(device, threads=threads) as launcher:
        # the view, then a frame looking down at the floor (surfaces everywhere), as a
        # moving view leaves one: the frame after it must write the background's values
        # itself, also where the first frame had them; then the view again, whose
        # background blocks hold their values already (the loop leaves them)
        down = make_camera_gpu(look_at_camera((0.0, 4.0, 0.0), (0.0, 0.0, -8.0), hfov_deg=70.0), W, H)
        Rasterizer(launcher).render(ds, cam, loop, StageTimer())
        Rasterizer(launcher).render(ds, down, loop, StageTimer())
        assert loop.hit_mask().mean() > 0.8
        Rasterizer(launcher).render(ds, cam, loop, StageTimer())
        Rasterizer(launcher).render(ds, cam, loop, StageTimer())
    hit = loop.hit_mask()
    # whole chunks of background (rows above the panels): the loop's shortcut for them,
    # and on the CPU their blocks known to hold the background record
    c = SURFACE_CHUNK_CPU
    assert (~hit[:, :c]).all(axis=1).any()
    if device == "cpu":
        blocks = loop.background_blocks.numpy()
        np.testing.assert_array_equal(blocks[:, 0] == 1, (~hit[:, :c]).all(axis=1))
    materials = loop.channel_numpy("material_id")
    # every path is taken: background, the floor and each panel; chunks whose runs of one
    # triangle are short (the gather lane by lane) and long (once a run); whole chunks in
    # rows that start a cache line (written in whole lines) and the others
    tris = loop.triangle_id.numpy().reshape(H, W)[:, : W - W % c].reshape(H, -1, c)
    runs = 1 + (tris[..., 1:] != tris[..., :-1]).sum(axis=-1)
    hit_chunks = (tris >= 0).any(axis=-1)
    assert (runs[hit_chunks] * SHORT_RUN_PIXELS > c).any() and (runs[hit_chunks] * SHORT_RUN_PIXELS <= c).any()
    assert 0.05 < hit.mean() < 0.95
    assert set(np.unique(materials[hit])) == set(range(len(scene.materials)))
    # the reference: the hit record copied, the background's values, the scalar surface
    scalar = GBuffer(W, H, device)
    scalar.clear()
    for name in ("triangle_id", "depth", "barycentric"):
        wp.copy(getattr(scalar, name), getattr(loop, name))
    wp.launch(scalar_surface_kernel, dim=(H, W), inputs=[ds.gpu, cam, scalar.rows()], device=device)
    for channel in CHANNELS:
        got, want = loop.channel_numpy(channel.name), scalar.channel_numpy(channel.name)
        if device == "cpu":
            assert got.tobytes() == want.tobytes(), channel.name
        else:
            np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6, err_msg=channel.name)
    # the floor's texture is minified (12 repeats of 56 texels across the view: the
    # vectorised taps' mip case), so its pixels average many texels and spread far less
    # than the image's colours
    floor = loop.channel_numpy("albedo")[materials == 0]
    assert len(floor) > 1000
    assert floor.std() < 0.25 * float(scene.images[0].pixels[..., :3].std())


class _ResolvePass(Rasterizer):
    """The raster path with the resolve as a pass of its own (``find_hits``), the surface
    pass then reading the hit record from the G-buffer."""

    def hits_for_surface(self, scene, camera, gbuffer, timer, rows=None):
        return PrimaryVisibility.hits_for_surface(self, scene, camera, gbuffer, timer, rows)


@pytest.mark.parametrize("threads", [1, 2])
def test_surface_pass_resolves_as_the_resolve_pass(device, threads):
    """A raster frame's surface pass resolves the hit record from the key slices itself:
    every channel, the hit record's included, the same bits as the resolve pass then the
    surface pass, over a moving view (blocks that hold the background record, kept or
    written again), every row or some."""
    scene, camera = _scene()
    ds = DeviceScene(scene, device)
    cam = make_camera_gpu(camera, W, H)
    down = make_camera_gpu(look_at_camera((0.0, 4.0, 0.0), (0.0, 0.0, -8.0), hfov_deg=70.0), W, H)
    fused, separate = GBuffer(W, H, device), GBuffer(W, H, device)
    with Launcher(device, threads=threads) as launcher:
        for view, rows in ((cam, None), (down, None), (cam, None), (cam, (13, 41)), (down, (0, 7)), (cam, None)):
            timer = StageTimer()
            Rasterizer(launcher).render(ds, view, fused, timer, rows)
            assert timer.stages_ms["resolve"] == 0.0 and timer.stages_ms["surface"] > 0.0
            _ResolvePass(launcher).render(ds, view, separate, StageTimer(), rows)
            assert 0.05 < fused.hit_mask().mean()
            for channel in CHANNELS:
                got, want = fused.channel_numpy(channel.name), separate.channel_numpy(channel.name)
                if device == "cpu":
                    assert got.tobytes() == want.tobytes(), (channel.name, rows)
                else:
                    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6, err_msg=channel.name)
            if device == "cpu":
                np.testing.assert_array_equal(fused.background_blocks.numpy(), separate.background_blocks.numpy())
