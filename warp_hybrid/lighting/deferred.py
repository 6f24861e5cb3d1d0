"""Deferred lighting: shade every G-buffer pixel (the lighting kernels' one module).

Per pixel: ``shading.shade_surface`` with the sum over the scene's lights of
``direct_light`` (times the per-light RGB transmittance when the shadow tracer has
filled one), i.e. emission + direct diffuse/specular + the dome's SH diffuse and
prefiltered glossy light (+ the raster approximation for transmissive materials).
Background pixels get the dome's radiance along the camera ray (black without a dome).
The shadowed and unshadowed variants are two kernels generated from one closure.

CPU performance notes: one kernel launch item is one image row (the launcher's
``launch_items``), so the big ``SceneGPU``/``AmbientGPU`` arguments are copied once per
row, not per pixel; every shading function is ``@wp.func(inline=True)`` (out of line,
each call would copy its struct arguments), with rare heavy paths (spot cones,
horizon-crossing rect lights) kept out of line; and the module compiles with FMA
contraction.
"""

from __future__ import annotations

import warp as wp

from ..parallel import Launcher
from ..raster.gbuffer import GBuffer
from ..scene.device import CameraGPU, DeviceScene, SceneGPU
from ..scene.environment import environment_radiance
from ..timing import StageTimer
from .ambient import AmbientGPU, EnvironmentLighting
from .shading import diffuse_albedo, direct_light, shade_surface

# FMA contraction across statements (what CUDA does by default): ~10-20% faster on the
# CPU; results change by rounding only.
_CPU_FLAGS = f"{wp.config.cpu_compiler_flags or '-march=native'} -ffp-contract=fast"
wp.set_module_options({"enable_backward": False, "cpu_compiler_flags": _CPU_FLAGS})


@wp.func(inline=True)
def camera_ray(cam: CameraGPU, x: int, y: int) -> wp.vec3:
    """World direction of the camera ray through the centre of pixel (x, y), not
    normalised (its component along ``forward`` is 1)."""
    ndc_x = 2.0 * (float(x) + 0.5) / float(cam.width) - 1.0
    ndc_y = 1.0 - 2.0 * (float(y) + 0.5) / float(cam.height)
    return cam.forward + cam.right * (ndc_x * cam.tan_x) + cam.up * (ndc_y * cam.tan_y)


@wp.func(inline=True)
def camera_ray_direction(cam: CameraGPU, x: int, y: int) -> wp.vec3:
    """Unit world direction of the camera ray through the centre of pixel (x, y)."""
    return wp.normalize(camera_ray(cam, x, y))


@wp.func(inline=True)
def shade_pixel(
    scene: SceneGPU,
    amb: AmbientGPU,
    cam: CameraGPU,
    position: wp.array2d(dtype=wp.vec3),
    normal: wp.array2d(dtype=wp.vec3),
    albedo: wp.array2d(dtype=wp.vec3),
    specular: wp.array2d(dtype=wp.vec3),
    emission: wp.array2d(dtype=wp.vec3),
    optics: wp.array2d(dtype=wp.vec4),
    material_id: wp.array2d(dtype=wp.int32),
    triangle_id: wp.array2d(dtype=wp.int32),
    transmittance: wp.array3d(dtype=wp.vec3),
    x: int,
    y: int,
    shadowed: bool,
) -> wp.vec3:
    """Outgoing radiance of pixel (x, y)."""
    if triangle_id[y, x] < 0:
        return environment_radiance(scene, camera_ray(cam, x, y))  # any length will do
    p = position[y, x]
    n = normal[y, x]
    v = wp.normalize(cam.origin - p)
    opt = optics[y, x]
    ior = opt[1]
    opacity = opt[2]
    roughness = opt[3]
    flags = int(0)
    mid = material_id[y, x]
    if mid >= 0:
        flags = scene.materials[mid].flags
    base = albedo[y, x]
    f0 = specular[y, x]
    kd = diffuse_albedo(scene, n, v, base, opacity, ior, flags)
    direct = wp.vec3(0.0, 0.0, 0.0)
    for i in range(scene.light_count):
        c = direct_light(scene, i, p, n, v, kd, f0, roughness)
        if shadowed:
            c = wp.cw_mul(c, transmittance[y, x, i])
        direct += c
    return shade_surface(scene, amb, n, v, base, kd, f0, roughness, emission[y, x], opacity, ior, flags, direct)


def _make_shade_kernel(shadowed: bool) -> wp.Kernel:
    """The per-pixel lighting kernel; ``shadowed`` multiplies each light by the
    transmittance buffer (H, W, L), otherwise that argument is ignored."""

    @wp.kernel
    def shade_pixels(
        scene: SceneGPU,
        amb: AmbientGPU,
        cam: CameraGPU,
        position: wp.array2d(dtype=wp.vec3),
        normal: wp.array2d(dtype=wp.vec3),
        albedo: wp.array2d(dtype=wp.vec3),
        specular: wp.array2d(dtype=wp.vec3),
        emission: wp.array2d(dtype=wp.vec3),
        optics: wp.array2d(dtype=wp.vec4),
        material_id: wp.array2d(dtype=wp.int32),
        triangle_id: wp.array2d(dtype=wp.int32),
        transmittance: wp.array3d(dtype=wp.vec3),
        skip_weight: wp.array2d(dtype=wp.float32),
        use_skip: int,
        color_out: wp.array2d(dtype=wp.vec3),
        row0: int,
        row_step: int,
    ):
        y = row0 + wp.tid() * row_step
        for x in range(color_out.shape[1]):
            if use_skip != 0:
                if skip_weight[y, x] >= 1.0:
                    continue
            color_out[y, x] = shade_pixel(
                scene,
                amb,
                cam,
                position,
                normal,
                albedo,
                specular,
                emission,
                optics,
                material_id,
                triangle_id,
                transmittance,
                x,
                y,
                wp.static(shadowed),
            )

    return shade_pixels


shade_unshadowed = _make_shade_kernel(False)
shade_shadowed = _make_shade_kernel(True)


class DeferredLighting:
    """The "lighting" stage: G-buffer in, linear HDR colour out."""

    def __init__(self, launcher: Launcher) -> None:
        """Shade on ``launcher``'s device, splitting rows across its threads."""
        self.launcher = launcher
        self._no_transmittance: wp.array | None = None
        self._no_skip = wp.zeros((1, 1), dtype=wp.float32, device=launcher.device)
        launcher.ensure_loaded(shade_unshadowed)  # compiles the lighting module up front

    def _dummy_transmittance(self) -> wp.array:
        if self._no_transmittance is None:
            self._no_transmittance = wp.ones((1, 1, 1), dtype=wp.vec3, device=self.launcher.device)
        return self._no_transmittance

    def shade(
        self,
        scene: DeviceScene,
        camera: CameraGPU,
        gbuffer: GBuffer,
        color_out: wp.array,
        timer: StageTimer,
        light_transmittance: wp.array | None = None,
        skip_weight: wp.array | None = None,
    ) -> None:
        """Write linear radiance (H, W) vec3 into ``color_out``.

        ``light_transmittance`` (H, W, L) vec3, L = number of lights, multiplies each
        light per pixel (shadows); None means unshadowed.  ``skip_weight`` (H, W)
        float32: pixels whose weight is >= 1 are left untouched (the hybrid mode's
        window interior, which the traced layer replaces anyway)."""
        h, w = gbuffer.height, gbuffer.width
        if tuple(color_out.shape) != (h, w) or (camera.width, camera.height) != (w, h):
            raise ValueError(
                f"color_out {tuple(color_out.shape)} and camera {camera.width}x{camera.height} "
                f"must match the G-buffer ({w}x{h})"
            )
        lights = scene.gpu.light_count
        if light_transmittance is None:
            kernel = shade_unshadowed
            transmittance = self._dummy_transmittance()
        else:
            expected = (h, w, lights)
            if lights > 0 and tuple(light_transmittance.shape) != expected:
                raise ValueError(
                    f"light_transmittance has shape {tuple(light_transmittance.shape)}, expected {expected}"
                )
            kernel = shade_shadowed
            transmittance = light_transmittance
        if skip_weight is not None and tuple(skip_weight.shape) != (h, w):
            raise ValueError(f"skip_weight has shape {tuple(skip_weight.shape)}, expected {(h, w)}")
        ambient = EnvironmentLighting.for_scene(scene)
        with timer.stage("lighting"):
            self.launcher.launch_items(
                kernel,
                h,
                [
                    scene.gpu,
                    ambient.gpu,
                    camera,
                    gbuffer.position,
                    gbuffer.normal,
                    gbuffer.albedo,
                    gbuffer.specular,
                    gbuffer.emission,
                    gbuffer.optics,
                    gbuffer.material_id,
                    gbuffer.triangle_id,
                    transmittance,
                    skip_weight if skip_weight is not None else self._no_skip,
                    1 if skip_weight is not None else 0,
                    color_out,
                ],
            )


def transmittance_buffer(height: int, width: int, lights: int, device: wp.context.Device | str) -> wp.array:
    """An all-ones (H, W, max(L, 1)) vec3 transmittance buffer for the shadow tracer to fill."""
    return wp.ones((height, width, max(lights, 1)), dtype=wp.vec3, device=device)
