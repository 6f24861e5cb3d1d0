"""Raster primary visibility: visibility buffer of depth|triangle keys, then resolve.

``Rasterizer.render`` runs three timed stages:

* ``raster``: the points are transformed once (``kernels.camera_points_kernel``),
  then every triangle is rasterized into a visibility buffer of packed 64-bit
  keys (float32 view-depth bits << 32 | triangle id) with one atomic min per covered
  pixel centre (see ``kernels.visibility_kernel``).  On a CPU, Warp's atomics are
  plain read-modify-writes and one launch runs on one thread, so the triangles are
  split between the launcher's threads and each thread owns one slice of the
  buffer; the resolve pass takes the minimum over the slices (no merge pass).
* ``resolve``: per pixel, the winning triangle is intersected with the pixel's
  camera ray for exact depth and barycentrics: the visibility record
  (``kernels.resolve_kernel``), the same one the ray-cast path writes.
* ``surface``: shared with the ray-cast path (``evaluate_surfaces``): per pixel the
  record's surface is evaluated, textures filtered (trilinear mip mapping) over the
  pixel's footprint (``kernels.surface_kernel``).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..parallel import Launcher
from ..scene.device import CameraGPU, DeviceScene
from ..timing import StageTimer
from . import kernels
from .gbuffer import GBuffer

_EMPTY_KEY = int(kernels.EMPTY_KEY.value)


def check_size(camera: CameraGPU, gbuffer: GBuffer) -> None:
    """Raise ``ValueError`` unless the camera was made for the G-buffer's size."""
    if (camera.width, camera.height) != (gbuffer.width, gbuffer.height):
        raise ValueError(
            f"camera is for {camera.width}x{camera.height} but the G-buffer is {gbuffer.width}x{gbuffer.height}"
        )


def evaluate_surfaces(
    launcher: Launcher, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer
) -> None:
    """The attribute pass both primary paths share (stage "surface"): from each
    pixel's visibility record (triangle, depth, barycentrics) evaluate the material
    and write every other G-buffer attribute."""
    with timer.stage("surface"):
        launcher.launch_rows(
            kernels.surface_kernel, gbuffer.height, gbuffer.width, [scene.gpu, camera, kernels.gbuffer_rows(gbuffer)]
        )


class Rasterizer:
    """Fills a ``GBuffer`` by rasterization (stages "raster" and "resolve")."""

    def __init__(self, launcher: Launcher) -> None:
        """Use ``launcher`` for the device and the host threads."""
        self.launcher = launcher
        self._vis: wp.array | None = None
        self._points: tuple[wp.array, wp.array] | None = None

    def _slices(self, height: int, width: int) -> wp.array:
        """The visibility buffer, one (height, width) slice per thread, reused."""
        shape = (self.launcher.threads, height, width)
        if self._vis is None or self._vis.shape != shape:
            self._vis = wp.empty(shape, dtype=wp.uint64, device=self.launcher.device)
        return self._vis

    def _transform_points(self, scene: DeviceScene, camera: CameraGPU) -> tuple[wp.array, wp.array]:
        """The scene's points in camera space and on screen (buffers reused between
        frames), see ``kernels.camera_points_kernel``."""
        count = len(scene.points)
        if self._points is None or self._points[0].shape[0] != count:
            self._points = tuple(wp.zeros(count, dtype=wp.vec3, device=self.launcher.device) for _ in range(2))
        self.launcher.launch_items(kernels.camera_points_kernel, count, [scene.gpu, camera, *self._points])
        return self._points

    def _rasterize(self, scene: DeviceScene, camera: CameraGPU, vis: wp.array, mode: int, clear: int) -> None:
        """Transform the points, then run the visibility kernel, each thread on every
        n-th triangle into its slice."""
        launcher = self.launcher
        launcher.ensure_loaded(kernels.visibility_kernel)
        count = scene.scene.triangle_count
        cam_points, screen_points = self._transform_points(scene, camera)

        def piece(k: int, n: int) -> None:
            vis[k].fill_(clear)
            tris = (count - k + n - 1) // n
            if tris > 0:
                wp.launch(
                    kernels.visibility_kernel,
                    dim=tris,
                    inputs=[scene.gpu, camera, cam_points, screen_points, vis, mode, k, k, n],
                    device=launcher.device,
                )

        launcher.run(piece, vis.shape[0])

    def render(self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer) -> None:
        """Rasterize ``scene`` seen by ``camera`` into ``gbuffer`` (every pixel written)."""
        check_size(camera, gbuffer)
        vis = self._slices(gbuffer.height, gbuffer.width)
        with timer.stage("raster"):
            self._rasterize(scene, camera, vis, kernels.MODE_DEPTH, _EMPTY_KEY)
        with timer.stage("resolve"):
            self.launcher.launch_rows(
                kernels.resolve_kernel,
                gbuffer.height,
                gbuffer.width,
                [scene.gpu, camera, vis, kernels.gbuffer_rows(gbuffer)],
            )
        evaluate_surfaces(self.launcher, scene, camera, gbuffer, timer)

    def overdraw(self, scene: DeviceScene, camera: CameraGPU) -> np.ndarray:
        """Diagnostic: (height, width) int64 count of rasterized fragments per pixel
        (depth complexity; 1 where a flat mesh covers a pixel exactly once)."""
        shape = (self.launcher.threads, camera.height, camera.width)
        vis = wp.empty(shape, dtype=wp.uint64, device=self.launcher.device)
        self._rasterize(scene, camera, vis, kernels.MODE_COUNT, 0)
        return vis.numpy().sum(axis=0).astype(np.int64)
