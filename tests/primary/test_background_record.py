"""Every primary pass writes every pixel: a G-buffer reused for a view that sees less
(nothing cleared in between) holds the background record, channel by channel, where the
new view sees no surface, and the same values as a fresh buffer everywhere."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import BACKGROUND, CHANNELS, GBuffer
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer, RayCaster
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Material
from warp_hybrid.timing import StageTimer

W, H = 64, 48


def _channels(gbuffer: GBuffer) -> dict[str, np.ndarray]:
    return {c.name: gbuffer.channel_numpy(c.name) for c in CHANNELS}


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_a_reused_gbuffer_holds_the_background_record_where_nothing_is_hit(device: str, path: str) -> None:
    meshes = [
        quad((-4.0, -4.0, 0.0), (8.0, 0.0, 0.0), (0.0, 8.0, 0.0), 0, "/wall"),
        uv_sphere((0.0, 0.0, 1.0), 0.5, rings=8, segments=16, material=1, name="/ball"),
    ]
    materials = [Material("wall", diffuse=(0.6, 0.5, 0.4), roughness=0.3), Material("ball", metallic=1.0)]
    near = look_at_camera((0.0, 0.0, 4.0), (0.0, 0.0, 0.0), hfov_deg=60.0)  # the wall fills the view
    far = look_at_camera((0.0, 0.0, 12.0), (0.0, 0.0, 0.0), hfov_deg=60.0)  # the wall leaves a border
    scene = DeviceScene(make_scene(meshes, materials, cameras=[near, far]), device)
    reused, fresh = GBuffer(W, H, device), GBuffer(W, H, device)
    with Launcher(device, threads=2) as launcher:
        primary = Rasterizer(launcher) if path == "raster" else RayCaster(launcher)
        primary.render(scene, make_camera_gpu(near, W, H), reused, StageTimer())
        assert reused.hit_mask().all()
        primary.render(scene, make_camera_gpu(far, W, H), reused, StageTimer())
        primary.render(scene, make_camera_gpu(far, W, H), fresh, StageTimer())
    background = ~reused.hit_mask()
    assert 0.2 < background.mean() < 0.9
    got, want = _channels(reused), _channels(fresh)
    for c in CHANNELS:
        assert np.array_equal(got[c.name], want[c.name]), c.name
        assert np.all(got[c.name][background] == BACKGROUND[c.name]), c.name
