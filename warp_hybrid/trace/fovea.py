"""The focus window supersampled (``RenderSettings.fovea_spp``): what hybrid rendering
saves outside the window, spent on a better fovea.

``FoveaSampler`` takes the hybrid frame's tracing step.  For each of the ``spp``
samples of the reference's stratified pattern (``supersample.sample_offsets``, the same
offsets and soft-shadow seeds as ``--mode full --spp N``), it casts the primary rays of
the window's pixels only (``primary.kernels.listed_primary_kernel``, stage
"fovea_primary", into a G-buffer of its own), traces them (stages "trace_shadow" and
"trace_secondary") and adds them to the sums (stage "accumulate").  The window's traced
layer and visibility AOV are then the box-filtered mean of its samples, so inside the
window's interior the image is the supersampled full ray tracing's, pixel for pixel (with
the ray-cast primary path; the raster path differs from it only along silhouettes).
The frame's G-buffer (its AOVs, the deferred lighting outside the window) stays at the
pixel centres.  Every sample costs a ray-cast primary and a traced path per window
pixel, so the window's cost grows with ``spp`` while the periphery's does not.

A supersampled window has no budget guard: the frame is not given a trace deadline
(``Renderer.render`` refuses one).
"""

from __future__ import annotations

import warp as wp

from ..core.camera import make_camera_gpu
from ..core.gbuffer import GBuffer
from ..core.passes import FrameContext, RenderPass
from ..primary import kernels as primary_kernels
from ..scene.device import DeviceScene
from ..supersample import SampleAccumulator, sample_offsets, sample_step
from .tracer import Tracer


class FoveaSampler(RenderPass):
    """Traces the focus region with ``spp`` samples per pixel (see the module docstring)."""

    def __init__(self, tracer: Tracer, spp: int, seed: int = 0) -> None:
        """Sample with ``tracer`` (and its launcher), ``spp`` samples per window pixel
        at the offsets ``sample_offsets(spp, seed)``."""
        self.tracer = tracer
        self.launcher = tracer.launcher
        self.spp = spp
        self.offsets = sample_offsets(spp, seed)
        self.step = sample_step(spp)
        self._accumulator = SampleAccumulator(self.launcher)
        self._gbuffer: GBuffer | None = None
        self._color: wp.array | None = None
        self._visibility: wp.array | None = None
        self.launcher.ensure_loaded(primary_kernels.listed_primary_kernel)

    def set_scene(self, scene: DeviceScene) -> None:
        """Draw ``scene`` (the tracer follows)."""
        super().set_scene(scene)
        self.tracer.set_scene(scene)

    def _scratch(self, width: int, height: int, lights: int) -> None:
        """The samples' own G-buffer, traced layer and visibility (NaN), for this size."""
        shape = (height, width, lights)
        if self._visibility is None or tuple(self._visibility.shape) != shape:
            device = self.launcher.device
            self._gbuffer = GBuffer(width, height, device)
            self._color = wp.zeros((height, width), dtype=wp.vec3, device=device)
            self._visibility = wp.full(shape, value=float("nan"), dtype=wp.float32, device=device)

    def execute(self, frame: FrameContext) -> None:
        """Write the mean of the window's samples into the frame's traced layer and
        visibility AOV (NaN outside the window); the ray counts of every sample go to
        ``frame.rays``."""
        assert self.scene is not None and frame.region is not None, "set_scene and a focus region first"
        assert frame.view is not None, "the frame's scene camera is needed to sample the pixels"
        b = frame.buffers
        w, h = b.width, b.height
        self._scratch(w, h, b.visibility.shape[2])
        region = frame.region
        self.tracer.begin_frame(w, h)
        wide = self.scene.query_bvh(self.tracer.wide_bvh).gpu
        b.visibility.fill_(float("nan"))
        for k, (sx, sy) in enumerate(self.offsets):
            camera = make_camera_gpu(frame.view, w, h, sample=(sx, sy), sample_step=self.step)
            with frame.timer.stage("fovea_primary"):
                self.launcher.launch_groups(
                    primary_kernels.listed_primary_kernel,
                    region.count,
                    [self.scene.gpu, wide, camera, self._gbuffer.rows(), region.pixels],
                )
            frame.rays = self.tracer.trace(
                self.scene,
                camera,
                self._gbuffer,
                region.pixels,
                region.count,
                self._color,
                self._visibility,
                frame.timer,
                sample_index=k,
            )
            with frame.timer.stage("accumulate"):
                self._accumulator.add(self._color, self._visibility, k == 0, region.pixels, region.count)
        with frame.timer.stage("accumulate"):
            self._accumulator.average(self.spp, b.traced_color, b.visibility, region.pixels, region.count)
