"""Deferred lighting: shade every G-buffer pixel (stage "lighting"; the lighting
kernel's one module).

Per pixel: ``shading.shade_surface`` with the sum over the scene's lights of
``direct_light``, i.e. emission + direct diffuse/specular + the dome's SH diffuse and
prefiltered glossy light (+ the raster approximation for transmissive materials).
Background pixels get the dome's radiance along the camera ray (black without a dome).
In hybrid mode the pixels of the focus window's interior (weight 1) are skipped: the
traced layer replaces them exactly.  When the budget guard stopped tracing short of
the planned window, ``refill`` shades just the skipped pixels the traced window does
not cover after all.

CPU performance notes: the kernel follows ``Launcher.launch_pixels`` (one launch item
per row on the CPU, so the big ``SceneGPU``/``AmbientGPU`` arguments are copied once
per row; one thread per pixel on CUDA); every shading function is
``@wp.func(inline=True)`` (out of line, each call would copy its struct arguments),
with rare heavy paths (spot cones, horizon-crossing rect lights) kept out of line; and
the module compiles with FMA contraction.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU, pixel_ray
from ..core.gbuffer import GBuffer, GBufferArrays
from ..core.passes import FrameContext, RenderPass
from ..core.scene_gpu import AmbientGPU, SceneGPU
from ..parallel import Launcher
from ..scene.device import DeviceScene
from ..scene.device.environment import environment_radiance
from ..timing import StageTimer
from .shading import diffuse_albedo, direct_light, shade_surface

# FMA contraction across statements (what CUDA does by default): ~10-20% faster on the
# CPU; results change by rounding only.
_CPU_FLAGS = f"{wp.config.cpu_compiler_flags or '-march=native'} -ffp-contract=fast"
wp.set_module_options({"enable_backward": False, "cpu_compiler_flags": _CPU_FLAGS})

# Which pixels ``shade_pixels`` shades.
SHADE_ALL = wp.constant(0)
SHADE_OUTSIDE = wp.constant(1)
SHADE_REFILL = wp.constant(2)


@wp.func(inline=True)
def shade_pixel(scene: SceneGPU, amb: AmbientGPU, cam: CameraGPU, gb: GBufferArrays, x: int, y: int) -> wp.vec3:
    """Outgoing radiance of pixel (x, y), unshadowed."""
    if gb.triangle_id[y, x] < 0:
        return environment_radiance(scene, pixel_ray(cam, x, y))  # any length will do
    p = gb.position[y, x]
    n = gb.normal[y, x]
    v = wp.normalize(cam.origin - p)
    opt = gb.optics[y, x]
    flags = int(0)
    mid = gb.material_id[y, x]
    if mid >= 0:
        flags = scene.materials[mid].flags
    base = gb.albedo[y, x]
    f0 = gb.specular[y, x]
    kd = diffuse_albedo(scene, n, v, base, opt.opacity, opt.ior, flags)
    direct = wp.vec3(0.0, 0.0, 0.0)
    for i in range(scene.light_count):
        direct += direct_light(scene, i, p, n, v, kd, f0, opt.roughness)
    return shade_surface(
        scene, amb, n, v, base, kd, f0, opt.roughness, gb.emission[y, x], opt.opacity, opt.ior, flags, direct
    )


@wp.kernel
def shade_pixels(
    scene: SceneGPU,
    amb: AmbientGPU,
    cam: CameraGPU,
    gb: GBufferArrays,
    skip_weight: wp.array2d(dtype=wp.float32),
    refill_weight: wp.array2d(dtype=wp.float32),
    mode: int,
    color_out: wp.array2d(dtype=wp.vec3),
    row0: int,
    row_step: int,
    cols: int,
):
    """Per pixel: ``shade_pixel`` into ``color_out``: every pixel (``mode`` SHADE_ALL),
    those whose skip weight is < 1 (SHADE_OUTSIDE), or only those whose skip weight is
    >= 1 and refill weight < 1 (SHADE_REFILL)."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, cam.width)):
        if mode != SHADE_ALL:
            skipped = skip_weight[y, x] >= 1.0
            if mode == SHADE_OUTSIDE and skipped:
                continue
            if mode == SHADE_REFILL and not (skipped and refill_weight[y, x] < 1.0):
                continue
        color_out[y, x] = shade_pixel(scene, amb, cam, gb, x, y)


class DeferredLighting(RenderPass):
    """The "lighting" stage: G-buffer in, linear HDR colour (the raster layer) out."""

    def __init__(self, launcher: Launcher) -> None:
        """Shade on ``launcher``'s device, splitting rows across its threads."""
        self.launcher = launcher
        self._no_skip = wp.zeros((1, 1), dtype=wp.float32, device=launcher.device)
        launcher.ensure_loaded(shade_pixels)  # compiles the lighting module up front

    def execute(self, frame: FrameContext) -> None:
        """Shade ``frame``'s G-buffer into its raster layer, skipping the focus region's
        interior when the frame has one."""
        assert self.scene is not None, "set_scene first"
        skip = frame.region.weight if frame.region is not None else None
        self.shade(self.scene, frame.camera, frame.gbuffer, frame.buffers.raster_color, frame.timer, skip)

    def shade(
        self,
        scene: DeviceScene,
        camera: CameraGPU,
        gbuffer: GBuffer,
        color_out: wp.array,
        timer: StageTimer,
        skip_weight: wp.array | None = None,
    ) -> None:
        """Write linear radiance (H, W) vec3 into ``color_out``.  ``skip_weight`` (H, W)
        float32: pixels whose weight is >= 1 are left untouched (the hybrid mode's
        window interior, which the traced layer replaces anyway)."""
        mode = SHADE_ALL if skip_weight is None else SHADE_OUTSIDE
        self._launch(scene, camera, gbuffer, color_out, timer, "lighting", mode, skip_weight=skip_weight)

    def refill(self, frame: FrameContext, skipped_weight: wp.array, traced_weight: wp.array) -> None:
        """Shade into ``frame``'s raster layer the pixels an earlier ``shade`` skipped
        (``skipped_weight`` >= 1) that the traced window does not replace
        (``traced_weight`` < 1) (stage "relight")."""
        assert self.scene is not None, "set_scene first"
        b = frame.buffers
        self._launch(
            self.scene, frame.camera, b.gbuffer, b.raster_color, frame.timer, "relight", SHADE_REFILL,
            skip_weight=skipped_weight, refill_weight=traced_weight,
        )  # fmt: skip

    def _launch(
        self,
        scene: DeviceScene,
        camera: CameraGPU,
        gbuffer: GBuffer,
        color_out: wp.array,
        timer: StageTimer,
        stage: str,
        mode: int,
        skip_weight: wp.array | None = None,
        refill_weight: wp.array | None = None,
    ) -> None:
        h, w = gbuffer.height, gbuffer.width
        if tuple(color_out.shape) != (h, w) or (camera.width, camera.height) != (w, h):
            raise ValueError(
                f"color_out {tuple(color_out.shape)} and camera {camera.width}x{camera.height} "
                f"must match the G-buffer ({w}x{h})"
            )
        for name, array in (("skip_weight", skip_weight), ("refill_weight", refill_weight)):
            if array is not None and tuple(array.shape) != (h, w):
                raise ValueError(f"{name} has shape {tuple(array.shape)}, expected {(h, w)}")
        inputs = [
            scene.gpu,
            scene.ambient,
            camera,
            gbuffer.kernel_arrays(),
            skip_weight if skip_weight is not None else self._no_skip,
            refill_weight if refill_weight is not None else self._no_skip,
            mode,
            color_out,
        ]
        with timer.stage(stage):
            self.launcher.launch_pixels(shade_pixels, gbuffer.height, gbuffer.width, inputs)
