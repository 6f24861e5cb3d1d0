"""Helpers for the primary-visibility tests: render a scene through either path."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer, RayCaster
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Camera, Scene
from warp_hybrid.timing import StageTimer


def render_gbuffer(
    scene: Scene | DeviceScene,
    camera: Camera,
    width: int,
    height: int,
    device: str,
    path: str = "raster",
    threads: int = 1,
    wide_bvh: bool | None = None,
) -> GBuffer:
    """Render one G-buffer with the raster or ray-cast path (``wide_bvh``: the ray
    cast's query, as ``RenderSettings.wide_bvh``)."""
    ds = scene if isinstance(scene, DeviceScene) else DeviceScene(scene, device)
    gbuffer = GBuffer(width, height, device)
    with Launcher(device, threads=threads) as launcher:
        renderer = Rasterizer(launcher) if path == "raster" else RayCaster(launcher, wide_bvh)
        renderer.render(ds, make_camera_gpu(camera, width, height), gbuffer, StageTimer())
    return gbuffer


def overdraw_counts(scene: Scene, camera: Camera, width: int, height: int, device: str, threads: int = 1) -> np.ndarray:
    """Fragments per pixel from the raster path."""
    with Launcher(device, threads=threads) as launcher:
        return Rasterizer(launcher).overdraw(DeviceScene(scene, device), make_camera_gpu(camera, width, height))


def pixel_rays(camera: Camera, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """float64 camera origin and (H, W, 3) ray directions through pixel centres, scaled
    so their component along the camera forward axis is 1 (t = view depth)."""
    m = np.asarray(camera.cam_to_world, np.float64)
    right, up, fwd = m[:3, 0], m[:3, 1], -m[:3, 2]
    tx = camera.tan_half_fov_x
    ty = camera.tan_half_fov_y(width, height)
    x = 2.0 * (np.arange(width) + 0.5) / width - 1.0
    y = 1.0 - 2.0 * (np.arange(height) + 0.5) / height
    d = fwd + (x[None, :, None] * tx) * right + (y[:, None, None] * ty) * up
    return m[:3, 3], d


@pytest.fixture
def render() -> Callable[..., GBuffer]:
    """``render(scene, camera, width, height, device, path="raster"|"raycast", threads=1,
    wide_bvh=None)``."""
    return render_gbuffer


@pytest.fixture
def overdraw() -> Callable[..., np.ndarray]:
    """``overdraw(scene, camera, width, height, device)`` -> fragments per pixel."""
    return overdraw_counts


@pytest.fixture
def rays() -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """``rays(camera, width, height)`` -> (origin, directions) in float64."""
    return pixel_rays
