"""Deferred lighting: shade every G-buffer pixel (stage "lighting"; the lighting
kernel's one module).

Per pixel: ``shading.shade_surface`` with the sum over the scene's lights of
``direct_light``, i.e. emission + direct diffuse/specular + the dome's SH diffuse and
prefiltered glossy light (+ the raster approximation for transmissive materials).
Background pixels get the dome's radiance along the camera ray (black without a dome).
With shadow maps (``RenderSettings.shadow_maps``; ``shadow_maps.py``) each light's direct
term is multiplied by its shadow-map visibility at the pixel's point (a kernel variant
of its own, so the unshadowed kernel is untouched); without them the raster layer is
unshadowed.
With a reflection probe (``RenderSettings.probes``; ``probes.py``) the glossy ambient
term reads the probe (the room captured by the rasterizer, the dome where it saw
background; ``probe_kernels.probe_specular``) instead of the dome alone: another kernel
variant (``PROBED_SHADE_KERNELS``, with or without shadow maps), so the kernel without
probes is untouched.
Every pixel is shaded in every mode, the focus window's too: the raster layer is whole,
so automatic exposure is metered on it whatever the window (one exposure per frame,
independent of the gaze), and wherever the budget guard stops tracing short of the
planned window the raster layer is already there.

CPU performance notes: the kernel follows ``Launcher.launch_pixels`` (one launch item
per row on the CPU, so the big ``SceneGPU``/``AmbientGPU`` arguments are copied once
per row; one thread per pixel on CUDA).  Without shadow maps and a probe, a native row
loop vectorised across pixels (``direct_rows.lit_span``) computes each pixel's whole
radiance and the row is done.  With a probe the lights' sum comes from the row loop
(``direct_span``, written into ``color_out`` and read back), then the per-pixel loop
adds the rest; with shadow maps one light at a time into ``color_out``, each term times
its visibility summed into a buffer of the pass's own, then the per-pixel loop.  The
module compiles with FMA contraction.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import warp as wp

from ..core.camera import CameraGPU, pixel_ray
from ..core.gbuffer import GBuffer, GBufferArrays
from ..core.native_rows import FMA_CONTRACTION_CPU_FLAGS, WIDE_VECTOR_CPU_FLAGS
from ..core.passes import FrameContext, MeteredRows, RenderPass
from ..core.rows import RowSpan
from ..core.scene_gpu import FLAG_TRANSMISSIVE, AmbientGPU, SceneGPU
from ..parallel import Launcher
from ..scene.device import DeviceScene
from ..scene.device.environment import environment_radiance
from ..timing import StageTimer
from .direct_rows import direct_span, lit_span
from .probe_kernels import ProbeGPU, probe_specular
from .shading import diffuse_albedo, shade_surface, shade_surface_with
from .shadow_map_kernels import ShadowMapsGPU, shadow_visibility

if TYPE_CHECKING:
    from .probes import ReflectionProbe
    from .shadow_maps import ShadowMaps

# FMA contraction across statements (what CUDA does by default): ~10-20% faster on the
# CPU; results change by rounding only.
_CPU_FLAGS = f"{WIDE_VECTOR_CPU_FLAGS} {FMA_CONTRACTION_CPU_FLAGS}"
wp.set_module_options({"enable_backward": False, "cpu_compiler_flags": _CPU_FLAGS})


@wp.func(inline=True)
def _flags(scene: SceneGPU, gb: GBufferArrays, x: int, y: int) -> int:
    """The material flags of pixel (x, y) (0 where it has no material)."""
    mid = gb.material_id[y, x]
    if mid >= 0:
        return scene.materials[mid].flags
    return 0


def _make_shade_kernel(shadowed: bool, probed: bool = False) -> wp.Kernel:
    """The lighting kernel: per pixel, ``shade_pixel`` into ``color_out``.  With
    ``shadowed`` each light's direct term is multiplied by its shadow-map visibility
    (``shadow_map_kernels.shadow_visibility``); with ``probed`` the glossy ambient is the
    reflection probe's (``probe_kernels.probe_specular``).  Either is a module of its own
    (compiled only when its switch is on, with the same options); without both, the
    maps and probe arguments are never read and the kernel is the lighting module's own,
    unchanged."""

    @wp.func(inline=True)
    def shade_pixel(
        scene: SceneGPU,
        amb: AmbientGPU,
        cam: CameraGPU,
        gb: GBufferArrays,
        probe: ProbeGPU,
        x: int,
        y: int,
        direct: wp.vec3,
    ) -> wp.vec3:
        """Outgoing radiance of pixel (x, y) given its (shadowed) ``direct`` light."""
        if gb.triangle_id[y, x] < 0:
            return environment_radiance(scene, pixel_ray(cam, x, y))  # any length will do
        p = gb.position[y, x]
        n = gb.normal[y, x]
        v = wp.normalize(cam.origin - p)
        opt = gb.optics[y, x]
        flags = _flags(scene, gb, x, y)
        base = gb.albedo[y, x]
        f0 = gb.specular[y, x]
        kd = diffuse_albedo(scene, n, v, base, opt.opacity, opt.ior, flags)
        if wp.static(probed):
            specular = probe_specular(scene, amb, probe, p, n, v, f0, opt.roughness)
            return shade_surface_with(
                scene, amb, n, v, base, kd, f0, gb.emission[y, x], opt.opacity, opt.ior, flags, direct, specular
            )
        return shade_surface(
            scene, amb, n, v, base, kd, f0, opt.roughness, gb.emission[y, x], opt.opacity, opt.ior, flags, direct
        )

    def shade_pixels(
        scene: SceneGPU,
        amb: AmbientGPU,
        cam: CameraGPU,
        gb: GBufferArrays,
        sm: ShadowMapsGPU,
        probe: ProbeGPU,
        direct: wp.array2d(dtype=wp.vec3),
        color_out: wp.array2d(dtype=wp.vec3),
        emissive: int,
        meter: int,
        meter_sum: wp.array(dtype=wp.float64),
        meter_count: wp.array(dtype=wp.int32),
        row0: int,
        row_step: int,
        cols: int,
    ):
        r, c = wp.tid()
        y = row0 + r * row_step
        first = c * cols
        stop = wp.min(first + cols, cam.width)
        if first >= stop:
            return
        if wp.static(shadowed):
            # each light's term (into color_out), times its visibility, summed into direct
            for x in range(first, stop):
                direct[y, x] = wp.vec3(0.0, 0.0, 0.0)
            for i in range(scene.light_count):
                direct_span(scene, cam, gb, color_out, i, i + 1, y, first, stop)
                for x in range(first, stop):
                    term = color_out[y, x]
                    if gb.triangle_id[y, x] >= 0 and (term[0] > 0.0 or term[1] > 0.0 or term[2] > 0.0):
                        transmissive = (_flags(scene, gb, x, y) & FLAG_TRANSMISSIVE) != 0
                        term = term * shadow_visibility(
                            scene, sm, i, gb.position[y, x], gb.geometric_normal[y, x], transmissive
                        )
                    direct[y, x] = direct[y, x] + term
        elif wp.static(probed):
            direct_span(scene, cam, gb, direct, 0, scene.light_count, y, first, stop)
        else:  # the whole radiance in the row loop
            lit_span(
                scene,
                amb,
                cam,
                gb,
                color_out,
                0,
                scene.light_count,
                emissive,
                meter,
                meter_sum,
                meter_count,
                y,
                first,
                stop,
            )
            return
        for x in range(first, stop):
            color_out[y, x] = shade_pixel(scene, amb, cam, gb, probe, x, y, direct[y, x])

    if shadowed or probed:
        options = {"enable_backward": False, "cpu_compiler_flags": _CPU_FLAGS}
        return wp.kernel(shade_pixels, module="unique", module_options=options)
    return wp.kernel(shade_pixels)


#: The lighting kernel without and with shadow maps (no probe).
SHADE_KERNELS = {shadowed: _make_shade_kernel(shadowed) for shadowed in (False, True)}
#: The lighting kernel with a reflection probe, without and with shadow maps.
PROBED_SHADE_KERNELS = {shadowed: _make_shade_kernel(shadowed, True) for shadowed in (False, True)}
#: The maps argument of the unshadowed kernel (never read).
_NO_MAPS = ShadowMapsGPU()
#: The probe argument of the kernels without a probe (never read).
_NO_PROBE = ProbeGPU()


def shade_kernel(shadowed: bool, probed: bool) -> wp.Kernel:
    """The lighting kernel for shadow maps on or off and a probe or none."""
    return (PROBED_SHADE_KERNELS if probed else SHADE_KERNELS)[shadowed]


class DeferredLighting(RenderPass):
    """The "lighting" stage: G-buffer in, linear HDR colour (the raster layer) out,
    shadowed by ``shadow_maps`` when given (the renderer's "shadow_maps" pass, which
    runs earlier in the frame), its glossy ambient from ``probe`` when given (the
    "probes" pass, after the maps)."""

    overlapped = True

    def __init__(
        self,
        launcher: Launcher,
        shadow_maps: ShadowMaps | None = None,
        probe: ReflectionProbe | None = None,
        meter: bool = False,
    ) -> None:
        """Shade on ``launcher``'s device, splitting rows across its threads; with ``meter``
        (the renderer's automatic exposure) the row loop meters the layer as it writes it
        where it can (``_meter_rows``) and leaves the sums in ``FrameContext.metered_rows``."""
        self.launcher = launcher
        self.shadow_maps = shadow_maps
        self.probe = probe
        self.meter = meter
        self._direct: wp.array | None = None
        self._sums: tuple[wp.array, wp.array] | None = None  # (row sums, row counts), reused
        self._no_sums = (
            wp.zeros(1, dtype=wp.float64, device=launcher.device),
            wp.zeros(1, dtype=wp.int32, device=launcher.device),
        )
        # compiles the lighting module (or the variant's) up front
        launcher.ensure_loaded(shade_kernel(shadow_maps is not None, probe is not None))

    def execute(self, frame: FrameContext) -> None:
        """Shade ``frame``'s G-buffer into its raster layer (every pixel of its ``raster_rows``)."""
        assert self.scene is not None, "set_scene first"
        maps = self.shadow_maps.gpu if self.shadow_maps is not None else None
        probe = self.probe.gpu if self.probe is not None else None
        color = frame.buffers.raster_color
        sums = self._meter_rows(frame)
        self.shade(self.scene, frame.camera, frame.gbuffer, color, frame.timer, maps, probe, frame.raster_rows, sums)
        frame.metered_rows = MeteredRows(color, *sums) if sums is not None else None

    def _meter_rows(self, frame: FrameContext) -> tuple[wp.array, wp.array] | None:
        """The row sums the row loop meters this frame's layer into, or None where it does
        not: without ``meter``, on CUDA (a launch item a pixel), where shadow maps or a
        probe take the per-pixel kernel, and where only some rows are drawn."""
        if not (self.meter and self.launcher.device.is_cpu and frame.raster_rows is None):
            return None
        if self.shadow_maps is not None or self.probe is not None:
            return None
        h = frame.gbuffer.height
        if self._sums is None or self._sums[0].shape[0] != h:
            dev = self.launcher.device
            self._sums = (wp.zeros(h, dtype=wp.float64, device=dev), wp.zeros(h, dtype=wp.int32, device=dev))
        return self._sums

    def shade(
        self,
        scene: DeviceScene,
        camera: CameraGPU,
        gbuffer: GBuffer,
        color_out: wp.array,
        timer: StageTimer,
        maps: ShadowMapsGPU | None = None,
        probe: ProbeGPU | None = None,
        rows: RowSpan | None = None,
        sums: tuple[wp.array, wp.array] | None = None,
    ) -> None:
        """Write the linear radiance of every pixel (of ``rows``, default every row) of
        ``gbuffer``, a G-buffer of ``scene`` (its emission channel is read only where the
        scene has an emissive material), (H, W) vec3, into ``color_out`` (each light's direct term times its visibility in ``maps``
        when given, the glossy ambient from ``probe`` when given); with ``sums`` (float64
        and int32 arrays of H, the row loop only: no maps, no probe, on the CPU) each row's
        log-luminance sum and count as the post stage meters them (``MeteredRows``)."""
        h, w = gbuffer.height, gbuffer.width
        if tuple(color_out.shape) != (h, w) or (camera.width, camera.height) != (w, h):
            raise ValueError(
                f"color_out {tuple(color_out.shape)} and camera {camera.width}x{camera.height} "
                f"must match the G-buffer ({w}x{h})"
            )
        if maps is not None:
            gbuffer.require_geometric_normals("the shadow-mapped lighting")
        kernel = shade_kernel(maps is not None, probe is not None)
        inputs = [
            scene.gpu,
            scene.ambient,
            camera,
            gbuffer.kernel_arrays(),
            _NO_MAPS if maps is None else maps,
            _NO_PROBE if probe is None else probe,
            color_out if maps is None else self._direct_sums(color_out),
            color_out,
            int(scene.features.emission),
            0 if sums is None else 1,
            *(self._no_sums if sums is None else sums),
        ]
        with timer.stage("lighting"):
            self.launcher.launch_pixels(kernel, h, w, inputs, rows=rows)

    def _direct_sums(self, color_out: wp.array) -> wp.array:
        """The shadowed kernel's buffer of each pixel's direct light (the lights' terms
        times their visibility, summed), shaped and placed as ``color_out``; allocated again
        only when that changes."""
        sums = self._direct
        if sums is None or (sums.shape, sums.device) != (color_out.shape, color_out.device):
            sums = self._direct = wp.empty(color_out.shape, dtype=wp.vec3, device=color_out.device)
        return sums
