"""Ray-traced shadows, reflections and refractions for a list of pixels.

``Tracer.trace`` takes the G-buffer and a compacted list of flat pixel indices (the
focus window, or every pixel for ``--mode full``) and writes, for each listed pixel,
the fully traced linear radiance and the per-light visibility AOV.  The work is
proportional to the list's length.  The list is cut into bands shared by the
launcher's threads as one pass of two stages (``Launcher.launch_staged``: on the native
band threads, the deadline asked natively); a thread runs both kernels on a band, one
after the other:

* the shadow kernel: shadow rays from the primary points (RGB transmittance per light;
  on the CPU eight neighbouring points' rays as one packet, ``shadows.shadow_launch``);
* the path kernel: shading of the primary point plus the reflection/refraction path
  with the shadow rays of its secondary hits (on the CPU a launch item takes
  ``parallel.ITEM_GROUP`` consecutive points, ``parallel.group_launch``).

The call's time is split between the stages "trace_shadow" and "trace_secondary" in
proportion to the time the threads spent in each kernel (one pass over the list, so a
call waits for its threads once, not once per kernel).  ``trace_rings`` traces a list
made of rings (the budget guard's, ``guard.py``) in ring order and, under a deadline,
starts a band of a ring after the first only while the clock says it ends in time at
the cost per pixel the call's bands took so far: the pixels traced are always the
list's first ones, and it stops within one band of the deadline.

Which kernel variant runs follows the scene's features (``variant.TraceVariant``):
the smallest one that covers the scene, re-chosen when a scene update changes the
features, unless the tracer was built for fixed features.  Ray counts are tallied by
screen tile on the device (``tally.RayTally``, accumulated over the ``trace`` calls of a
frame) and read by the caller after the frame, so a frame has no host sync inside it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import warp as wp

from ..core.camera import CameraGPU
from ..core.features import SceneFeatures
from ..core.gbuffer import GBuffer
from ..core.passes import FrameContext, RenderPass
from ..errors import RenderSettingsError
from ..parallel import MIN_BAND_ITEMS, Launcher, StagedBand, band, band_count, group_launch, item_group
from ..scene.device import DeviceScene
from ..scene.device.wide_bvh import use_wide_bvh
from ..timing import StageTimer
from .occluders import Occluders
from .path import COUNT_COLUMNS, MAX_DEPTH, path_kernel
from .rays import TraceFrame, TraceParams
from .shadow_cache import ShadowCache
from .shadows import shadow_kernel, shadow_launch
from .tally import TALLY_BAND_ITEMS, RayTally, tally_tiles
from .variant import TraceVariant


@dataclass
class TraceSettings:
    """How much tracing a pixel gets.

    ``max_depth``: secondary bounces (reflection/refraction) per path, 0..8.
    ``shadow_samples``: 1 = hard shadows from each light's centre; N > 1 = N samples
    over sphere, rect, disk and angular distant lights (soft shadows).
    ``seed``: seeds the soft-shadow samples (per pixel, deterministic); sample k of a
    supersampled frame uses ``sample_seed(seed, k)``.
    ``wide_bvh``: query the 4-wide BVH copies (``wide_bvh.py``; the same answers, faster)
    instead of Warp's own queries; CPU only; None: on the CPU, not on CUDA.
    ``keep_shadows``: in the kept frames of a still view (``FrameContext.raster_cached``)
    reuse the primary hits' shadows the view has traced (``shadow_cache.py``; the same
    image bit for bit, fewer shadow rays).
    """

    max_depth: int = 3
    shadow_samples: int = 1
    seed: int = 0
    wide_bvh: bool | None = None
    keep_shadows: bool = True

    def validate(self) -> None:
        """Raise ``RenderSettingsError`` for values the kernels cannot honour."""
        if not 0 <= self.max_depth <= MAX_DEPTH:
            raise RenderSettingsError(f"max depth must be in 0..{MAX_DEPTH}, got {self.max_depth}")
        if self.shadow_samples < 1:
            raise RenderSettingsError(f"shadow samples must be >= 1, got {self.shadow_samples}")


#: The soft-shadow seed's step per sample: a prime no sum of the kernel's own steps per
#: light (7919) and per path segment (104729) reaches for 256 samples, 64 lights and 16
#: segments, and small enough that the seeds of 256 samples stay far from int32 overflow.
SAMPLE_SEED_STEP = 1000003


def sample_seed(seed: int, sample_index: int) -> int:
    """The soft-shadow seed of sub-frame ``sample_index`` of a supersampled frame:
    ``seed`` itself for sample 0, then one ``SAMPLE_SEED_STEP`` per sample, so each
    sample draws other shadow samples and soft shadows converge too."""
    return int(seed) + int(sample_index) * SAMPLE_SEED_STEP


class Tracer(RenderPass):
    """Traces the secondary effects of a list of pixels (see the module docstring)."""

    def __init__(self, launcher: Launcher, settings: TraceSettings, features: SceneFeatures | None = None) -> None:
        """Trace on ``launcher``; ``features`` fixes the compiled variant (e.g.
        ``SceneFeatures.all()``), None picks the smallest one for each scene set."""
        settings.validate()
        self.launcher = launcher
        self.settings = settings
        #: Whether the queries use the 4-wide BVH copies (``use_wide_bvh``).
        self.wide_bvh = use_wide_bvh(settings.wide_bvh, launcher.device)
        self.fixed_features = features
        self.variant: TraceVariant | None = None
        if features is not None:
            self._use_variant(TraceVariant.for_scene(features, settings.shadow_samples, self.wide_bvh))
        self._transmittance: wp.array | None = None
        self._counts: wp.array | None = None
        self._occluders: Occluders | None = None
        self._shadow_cache = ShadowCache(launcher.device)
        self.tally: RayTally | None = None

    def _use_variant(self, variant: TraceVariant) -> None:
        """Compile (once per process) and load the kernels of ``variant``."""
        if variant == self.variant:
            return
        self.variant = variant
        self.shadow_kernel = shadow_kernel(*variant.shadow_key()) if variant.shadows else None
        self.path_kernel = path_kernel(variant)
        if self.shadow_kernel is not None:
            self.launcher.ensure_loaded(self.shadow_kernel)
        self.launcher.ensure_loaded(self.path_kernel)

    def execute(self, frame: FrameContext) -> None:
        """Trace ``frame.region`` into the frame's traced layer and visibility AOV (NaN
        outside the region); the ray counts go to ``frame.rays`` (summed over the
        samples of a supersampled frame)."""
        assert self.scene is not None and frame.region is not None, "set_scene and a focus region first"
        b = frame.buffers
        if frame.sample_index == 0:
            self.begin_frame(b.gbuffer.width, b.gbuffer.height)
        b.visibility.fill_(float("nan"))
        region = frame.region
        frame.rays = self.trace(
            self.scene,
            frame.camera,
            b.gbuffer,
            region.pixels,
            region.count,
            b.traced_color,
            b.visibility,
            frame.timer,
            sample_index=frame.sample_index,
            reuse_shadows=frame.raster_cached and self.settings.keep_shadows,
        )

    def begin_frame(self, width: int, height: int) -> RayTally:
        """Clear the ray tally for a new ``width`` x ``height`` frame (``trace`` calls add to it)."""
        if self.tally is None or (self.tally.width, self.tally.height) != (width, height):
            self.tally = RayTally(width, height, self.launcher.threads, self.launcher.device)
        else:
            self.tally.clear()
        return self.tally

    def set_scene(self, scene: DeviceScene) -> None:
        """Make the tracer ready for ``scene`` (after an update too): a variant that
        covers its features, and its shadow BVHs.  Raises ``ValueError`` when the tracer
        was built for fixed features the scene exceeds."""
        if self.fixed_features is None:
            needed = TraceVariant.for_scene(scene.features, self.settings.shadow_samples, self.wide_bvh)
            if self.variant is None or not self.variant.covers(scene.features):
                self._use_variant(needed)
        else:
            missing = scene.features.missing_from(self.fixed_features)
            if missing:
                raise ValueError(
                    f"{scene.scene.path}: the tracer was built without {', '.join(missing)}, which the scene needs"
                )
        if self._occluders is not None and not self._occluders.matches(scene):
            self._occluders = None
        self.scene = scene

    def _occluders_for(self, scene: DeviceScene, timer: StageTimer) -> Occluders:
        """The shadow BVHs of ``scene``: built on first use (stage "trace_setup"),
        refitted when its points moved."""
        if self._occluders is None or not self._occluders.matches(scene):
            with timer.stage("trace_setup"):
                self._occluders = Occluders(scene, wide=self.wide_bvh)
        else:
            self._occluders.refresh()
        return self._occluders

    def _scratch(self, count: int, lights: int) -> tuple[wp.array, wp.array]:
        """Per-item transmittance (count, L) and ray counts (count, 4), reused across calls."""
        shape_t = (max(count, 1), max(lights, 1))
        dev = self.launcher.device
        if (
            self._transmittance is None
            or self._transmittance.shape[0] < shape_t[0]
            or self._transmittance.shape[1] != shape_t[1]
        ):
            self._transmittance = wp.empty(shape_t, dtype=wp.vec3, device=dev)
        if self._counts is None or self._counts.shape[0] < shape_t[0]:
            self._counts = wp.empty((shape_t[0], COUNT_COLUMNS), dtype=wp.int32, device=dev)
        return self._transmittance, self._counts

    def _params(self, sample_index: int) -> TraceParams:
        p = TraceParams()
        p.max_depth = self.settings.max_depth
        p.shadow_samples = self.settings.shadow_samples
        p.seed = sample_seed(self.settings.seed, sample_index)
        return p

    @staticmethod
    def _check(
        gbuffer: GBuffer,
        camera: CameraGPU,
        pixels: wp.array,
        count: int,
        color_out: wp.array,
        visibility_out: wp.array,
        lights: int,
    ) -> None:
        h, w = gbuffer.height, gbuffer.width
        if (camera.width, camera.height) != (w, h):
            raise ValueError(f"camera is for {camera.width}x{camera.height} but the G-buffer is {w}x{h}")
        if tuple(color_out.shape) != (h, w):
            raise ValueError(f"color_out has shape {tuple(color_out.shape)}, expected {(h, w)}")
        if lights > 0 and tuple(visibility_out.shape) != (h, w, lights):
            raise ValueError(f"visibility_out has shape {tuple(visibility_out.shape)}, expected {(h, w, lights)}")
        if not 0 <= count <= pixels.shape[0]:
            raise ValueError(f"count {count} is outside the pixel list (length {pixels.shape[0]})")

    def trace(
        self,
        scene: DeviceScene,
        camera: CameraGPU,
        gbuffer: GBuffer,
        pixels: wp.array,
        count: int,
        color_out: wp.array,
        visibility_out: wp.array,
        timer: StageTimer,
        sample_index: int = 0,
        reuse_shadows: bool = False,
    ) -> RayTally:
        """Trace the first ``count`` pixels of ``pixels`` (int32 flat indices row * W + col).

        Writes ``color_out[y, x]`` (traced linear radiance) for each listed pixel and,
        where it hit a surface, ``visibility_out[y, x, i]`` (luminance of the RGB
        transmittance toward light i, in [0, 1]; 0 also where the light cannot reach the
        point at all); other pixels, and list entries outside the image, are
        untouched.  Stages "trace_shadow" and "trace_secondary" go to ``timer`` (and
        "trace_setup" when the shadow BVHs are built, on the first call for a scene).
        The ray counts are added to the frame's tally (``begin_frame`` clears it; the
        first call for a tracer does), which is returned, still on the device.
        ``sample_index``: the sub-frame of a supersampled frame (its soft-shadow seed,
        ``sample_seed``).  ``reuse_shadows``: the caller's word that the camera and the
        G-buffer are the last call's (a kept frame of a still view): the primary hits'
        shadows traced since then are reused (``shadow_cache.py``).  Raises
        ``ValueError`` on mismatched shapes or a scene needing effects the tracer was not
        built for."""
        self.trace_rings(
            scene, camera, gbuffer, pixels, [count], color_out, visibility_out, timer, None, sample_index, reuse_shadows
        )
        assert self.tally is not None
        return self.tally

    def trace_rings(
        self,
        scene: DeviceScene,
        camera: CameraGPU,
        gbuffer: GBuffer,
        pixels: wp.array,
        ring_ends: Sequence[int],
        color_out: wp.array,
        visibility_out: wp.array,
        timer: StageTimer,
        deadline: float | None = None,
        sample_index: int = 0,
        reuse_shadows: bool = False,
    ) -> int:
        """``trace`` for the pixels ``pixels[0:ring_ends[-1]]``, made of the rings
        ``pixels[ring_ends[k - 1]:ring_ends[k]]``, in ring order (module docstring): the
        first ring whole, the others while the clock (``timer.now()``) says a band ends
        by ``deadline`` (None: every ring).  Returns how many rings were traced whole
        (the pixels of a ring cut short are traced, and counted in the tally, but no
        ring is counted for them).  ``sample_index``, ``reuse_shadows``: as ``trace``."""
        self.set_scene(scene)
        lights = scene.gpu.light_count
        ends = [int(e) for e in ring_ends]
        if any(b < a for a, b in zip([0, *ends], ends)):
            raise ValueError(f"ring ends must not decrease, got {ends}")
        count = ends[-1] if ends else 0
        self._check(gbuffer, camera, pixels, count, color_out, visibility_out, lights)
        tally = self.tally if self.tally is not None else self.begin_frame(gbuffer.width, gbuffer.height)
        if count == 0:
            return len(ends)
        transmittance, counts = self._scratch(count, lights)
        counts.zero_()
        occluders = self._occluders_for(scene, timer)
        tf = TraceFrame()
        tf.cam = camera
        tf.params = self._params(sample_index)
        tf.occ = occluders.gpu
        tf.gb = gbuffer.kernel_arrays()
        tf.pixels = pixels
        tf.transmittance = transmittance
        tf.counts = counts
        shadow = self.shadow_kernel if lights > 0 else None
        # what the primary hits' shadows depend on besides the view (the caller's word);
        # the objects themselves, compared by identity (an id could be a freed object's)
        state = (scene, scene.content_version, occluders, self.variant, gbuffer, sample_index)
        cache = self._shadow_cache.frame(gbuffer.height, gbuffer.width, lights, state, reuse_shadows)
        shadow_inputs = [scene.gpu, tf, visibility_out, cache]
        path_inputs = [scene.gpu, scene.ambient, tf, color_out]
        bands = ring_bands(ends, band_count(count, self.launcher.threads, MIN_BAND_ITEMS))
        group = item_group(self.launcher.device)
        stages = [(shadow, shadow_inputs)] if shadow is not None else []
        stages.append((self.path_kernel, path_inputs))
        staged = [
            StagedBand(
                (
                    *((shadow_launch(self.variant.wide_bvh, first, items),) if shadow is not None else ()),
                    group_launch(first, items, group),
                ),
                items,
                must=ring == 0,
            )
            for first, items, ring in bands
        ]
        start = timer.now()
        run = self.launcher.launch_staged(stages, staged, timer, deadline)
        ran = run.ran
        traced = bands[ran - 1][0] + bands[ran - 1][1] if ran > 0 else 0
        self.launcher.launch_slots(
            tally_tiles,
            traced,
            [pixels, counts, gbuffer.width, gbuffer.height, tally.tiles_x, tally.table],
            min_band_items=TALLY_BAND_ITEMS,
        )
        tally.items += traced
        total_ms = (timer.now() - start) * 1000.0
        busy = float(run.seconds.sum())
        shadow_ms = total_ms * float(run.seconds[:, 0].sum()) / busy if busy > 0.0 and shadow is not None else 0.0
        timer.add("trace_shadow", shadow_ms)
        timer.add("trace_secondary", total_ms - shadow_ms)
        return sum(1 for e in ends if e <= traced)


def ring_bands(ring_ends: Sequence[int], bands: int) -> list[tuple[int, int, int]]:
    """The bands (first item, items, ring) ``Tracer.trace_rings`` cuts the rings ending at
    ``ring_ends`` into: about ``bands`` over the whole list, each ring its own bands in
    proportion to its share of the list (one at least, none for an empty ring), the
    sizes within a ring differing by at most one."""
    total = ring_ends[-1] if ring_ends else 0
    out: list[tuple[int, int, int]] = []
    for ring, (lo, hi) in enumerate(zip([0, *ring_ends[:-1]], ring_ends)):
        items = hi - lo
        if items <= 0:
            continue
        n = max(1, min(items, math.ceil(items * bands / total)))
        out.extend((lo + first, size, ring) for first, size in (band(k, n, items) for k in range(n)))
    return out
