"""The ray-cast primaries give the same G-buffer through the scene's 4-wide BVH copy as
through Warp's own query, on an analytic scene, through cut-out holes and on shared
scenes; the setting resolves as the tracer's does."""

from __future__ import annotations

import json

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.gbuffer import CHANNELS, GBuffer
from warp_hybrid.errors import RenderSettingsError
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import RayCaster
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Camera, Material, Scene, TextureBinding, TextureImage, Wrap

W, H = 128, 96


def _spheres_scene() -> tuple[Scene, Camera]:
    meshes = [
        quad((-6.0, 0.0, 6.0), (12.0, 0.0, 0.0), (0.0, 0.0, -12.0), 0, "/floor"),
        uv_sphere((0.0, 0.8, 0.0), 0.8, rings=24, segments=48, material=1, name="/ball"),
        uv_sphere((1.6, 0.4, 0.9), 0.4, rings=12, segments=24, material=1, name="/small"),
    ]
    cam = look_at_camera((2.5, 2.0, 4.5), (0.0, 0.6, 0.0), hfov_deg=55.0)
    return make_scene(meshes, [Material("floor"), Material("ball")], cameras=[cam]), cam


def _cutout_scene() -> tuple[Scene, Camera]:
    """A checker-cut leaf in front of a back plane, so most rays step past cut-away hits."""
    tex = np.zeros((8, 8, 4), np.float32)
    tex[..., 3] = (np.add.outer(np.arange(8), np.arange(8)) % 2).astype(np.float32)
    meshes = [
        quad((-1.0, -1.0, 0.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), 0, "/leaf"),
        quad((-3.0, -3.0, -2.0), (6.0, 0.0, 0.0), (0.0, 6.0, 0.0), 1, "/back"),
    ]
    leaf = Material("leaf", opacity_texture=0, opacity_channel=3, opacity_threshold=0.5)
    cam = look_at_camera((0.0, 0.0, 3.0), (0.0, 0.0, 0.0), hfov_deg=50.0)
    scene = make_scene(
        meshes,
        [leaf, Material("back")],
        cameras=[cam],
        images=[TextureImage("<checker>", tex)],
        textures=[TextureBinding(0, Wrap.CLAMP, Wrap.CLAMP)],
    )
    return scene, cam


def _assert_same_gbuffer(wide: GBuffer, warp: GBuffer, min_same: float) -> None:
    """The same triangle on at least ``min_same`` of the pixels (a pixel centre exactly
    on a shared edge may pick either triangle) and, where the triangle is the same,
    every channel bit for bit (the hit record is recomputed from the face)."""
    ta, tb = wide.triangle_id.numpy(), warp.triangle_id.numpy()
    same = ta == tb
    assert same.mean() >= min_same
    assert (ta >= 0).sum() > 0.2 * ta.size
    for channel in CHANNELS:
        np.testing.assert_array_equal(
            wide.channel_numpy(channel.name)[same], warp.channel_numpy(channel.name)[same], err_msg=channel.name
        )


@pytest.mark.parametrize("make", [_spheres_scene, _cutout_scene], ids=["spheres", "cutout"])
def test_wide_and_warp_queries_give_the_same_gbuffer(device: str, render, make) -> None:
    if not wp.get_device(device).is_cpu:
        pytest.skip("the 4-wide copies are CPU only")
    scene, cam = make()
    wide = render(scene, cam, W, H, device, "raycast", wide_bvh=True)
    warp = render(scene, cam, W, H, device, "raycast", wide_bvh=False)
    _assert_same_gbuffer(wide, warp, 0.999)


def test_the_cutout_scene_sees_the_back_plane_through_the_holes(device: str, render) -> None:
    scene, cam = _cutout_scene()
    tri = render(scene, cam, W, H, device, "raycast").triangle_id.numpy()
    back = scene.meshes[1]
    on_back = (tri >= back.first_triangle) & (tri < back.first_triangle + back.triangle_count)
    centre = on_back[H // 2 - 20 : H // 2 + 20, W // 2 - 20 : W // 2 + 20]
    assert 0.35 < centre.mean() < 0.65  # half the leaf's checker cells are holes


@pytest.mark.parametrize("name", ["smoke_test", "cornell_box_glass_mirror"])
def test_wide_and_warp_queries_agree_on_shared_scenes(device: str, render, shared_scenes, name: str) -> None:
    if not wp.get_device(device).is_cpu:
        pytest.skip("the 4-wide copies are CPU only")
    loader = pytest.importorskip("warp_hybrid.scene.usd.loader")
    entry = {s["name"]: s for s in json.loads((shared_scenes / "manifest.json").read_text())["scenes"]}[name]
    scene = loader.load_scene(shared_scenes / entry["file"])
    wide = render(scene, scene.cameras[0], W, H, device, "raycast", wide_bvh=True)
    warp = render(scene, scene.cameras[0], W, H, device, "raycast", wide_bvh=False)
    _assert_same_gbuffer(wide, warp, 0.999)


def test_the_setting_resolves_as_the_tracers(device: str) -> None:
    with Launcher(device, threads=1) as launcher:
        cpu = wp.get_device(device).is_cpu
        assert RayCaster(launcher).wide_bvh == cpu
        assert RayCaster(launcher, False).wide_bvh is False
        if cpu:
            assert RayCaster(launcher, True).wide_bvh is True
        else:
            with pytest.raises(RenderSettingsError, match="CPU only"):
                RayCaster(launcher, True)
