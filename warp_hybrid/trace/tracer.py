"""Ray-traced shadows, reflections and refractions for a list of pixels.

``Tracer.trace`` takes the G-buffer and a compacted list of flat pixel indices (the
focus window, or every pixel for ``--mode full``) and writes, for each listed pixel,
the fully traced linear radiance and the per-light visibility AOV.  The work is
proportional to the list's length.  Two timed stages, each launched over the list
split between the launcher's threads:

* "trace_shadow": shadow rays from the primary points (RGB transmittance per light);
* "trace_secondary": shading of the primary point plus the reflection/refraction path
  with the shadow rays of its secondary hits.

Which kernel variant runs follows the scene's features (``TraceVariant``); see
``trace/kernels.py`` for the rules.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from ..errors import RenderSettingsError
from ..lighting.ambient import EnvironmentLighting
from ..parallel import Launcher
from ..raster.gbuffer import GBuffer
from ..raster.kernels import gbuffer_arrays
from ..scene.device import CameraGPU, DeviceScene
from ..scene.model import SceneFeatures
from ..timing import StageTimer
from . import kernels
from .occluders import Occluders


# The SceneFeatures flags that select kernel code (textures need none).
TRACED_FEATURES = ("shadows", "reflections", "refractions", "transparency", "environment", "emission", "cutouts")


@dataclass
class TraceSettings:
    """How much tracing a pixel gets.

    ``max_depth``: secondary bounces (reflection/refraction) per path, 0..8.
    ``shadow_samples``: 1 = hard shadows from each light's centre; N > 1 = N samples
    over sphere, rect, disk and angular distant lights (soft shadows).
    ``seed``: seeds the soft-shadow samples (per pixel, deterministic).
    """

    max_depth: int = 3
    shadow_samples: int = 1
    seed: int = 0

    def validate(self) -> None:
        """Raise ``RenderSettingsError`` for values the kernels cannot honour."""
        if not 0 <= self.max_depth <= kernels.MAX_DEPTH:
            raise RenderSettingsError(f"max depth must be in 0..{kernels.MAX_DEPTH}, got {self.max_depth}")
        if self.shadow_samples < 1:
            raise RenderSettingsError(f"shadow samples must be >= 1, got {self.shadow_samples}")


@dataclass
class RayCounts:
    """Rays launched by one ``trace`` call (logical rays: a shadow ray stepping through
    several transparent surfaces counts once)."""

    traced_pixels: int
    shadow: int
    reflection: int
    refraction: int

    def to_dict(self) -> dict[str, int]:
        """JSON-ready counts."""
        return {
            "traced_pixels": self.traced_pixels,
            "shadow": self.shadow,
            "reflection": self.reflection,
            "refraction": self.refraction,
        }


def trace_variant(features: SceneFeatures, settings: TraceSettings) -> kernels.TraceVariant:
    """The kernel flags for a scene with these features traced with these settings."""
    transparency = features.transparency or features.refractions
    return kernels.TraceVariant(
        shadows=features.shadows,
        layered_shadows=transparency or features.cutouts or features.emission,
        soft_shadows=settings.shadow_samples > 1,
        reflections=features.reflections or transparency,
        transparency=transparency,
        refractions=features.refractions,
        environment=features.environment,
        cutouts=features.cutouts,
    )


class Tracer:
    """Traces the secondary effects of a list of pixels (see the module docstring)."""

    def __init__(self, launcher: Launcher, features: SceneFeatures, settings: TraceSettings) -> None:
        """Pick (and compile, once per process) the kernel variants ``features`` need."""
        settings.validate()
        self.launcher = launcher
        self.features = features
        self.settings = settings
        self.variant = trace_variant(features, settings)
        self.shadow_kernel = kernels.shadow_kernel(*self.variant.shadow_key()) if self.variant.shadows else None
        self.shade_kernel = kernels.shade_kernel(self.variant)
        if self.shadow_kernel is not None:
            launcher.ensure_loaded(self.shadow_kernel)
        launcher.ensure_loaded(self.shade_kernel)
        self._transmittance: wp.array | None = None
        self._counts: wp.array | None = None
        self._occluders: Occluders | None = None

    def _occluders_for(self, scene: DeviceScene, timer: StageTimer) -> Occluders:
        """The shadow BVHs of ``scene``: built on first use (stage "trace_setup"),
        refitted when its points moved."""
        if self._occluders is None or self._occluders.scene is not scene:
            with timer.stage("trace_setup"):
                self._occluders = Occluders(scene)
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
            self._counts = wp.empty((shape_t[0], kernels.COUNT_COLUMNS), dtype=wp.int32, device=dev)
        return self._transmittance, self._counts

    def _params(self, occluders: Occluders) -> kernels.TraceParams:
        p = kernels.TraceParams()
        p.scale = occluders.scale
        p.max_depth = self.settings.max_depth
        p.shadow_samples = self.settings.shadow_samples
        p.seed = self.settings.seed
        return p

    def _check_features(self, scene: DeviceScene) -> None:
        """The compiled variant must cover every effect the scene needs."""
        missing = [
            name for name in scene.features.names() if name in TRACED_FEATURES and not getattr(self.features, name)
        ]
        if missing:
            raise ValueError(
                f"{scene.scene.path}: the tracer was built without {', '.join(missing)}, which the scene needs"
            )

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
    ) -> RayCounts:
        """Trace the first ``count`` pixels of ``pixels`` (int32 flat indices row * W + col).

        Writes ``color_out[y, x]`` (traced linear radiance) for each listed pixel and,
        where it hit a surface, ``visibility_out[y, x, i]`` (luminance of the RGB
        transmittance toward light i, in [0, 1]; 0 also where the light cannot reach the
        point at all); other pixels, and list entries outside the image, are
        untouched.  Stages "trace_shadow" and "trace_secondary" go to ``timer`` (and
        "trace_setup" when the shadow BVHs are built, on the first call for a scene).
        Raises ``ValueError`` on mismatched shapes or a scene needing effects the
        tracer was not built for."""
        lights = scene.gpu.light_count
        self._check_features(scene)
        self._check(gbuffer, camera, pixels, count, color_out, visibility_out, lights)
        if count == 0:
            return RayCounts(0, 0, 0, 0)
        transmittance, counts = self._scratch(count, lights)
        counts.zero_()
        occluders = self._occluders_for(scene, timer)
        params = self._params(occluders)
        occ = occluders.gpu
        gb = gbuffer_arrays(gbuffer)
        with timer.stage("trace_shadow"):
            if self.shadow_kernel is not None and lights > 0:
                self.launcher.launch_items(
                    self.shadow_kernel,
                    count,
                    [scene.gpu, camera, params, occ, gb, pixels, transmittance, visibility_out, counts],
                )
        ambient = EnvironmentLighting.for_scene(scene)
        with timer.stage("trace_secondary"):
            self.launcher.launch_items(
                self.shade_kernel,
                count,
                [scene.gpu, ambient.gpu, camera, params, occ, gb, pixels, transmittance, color_out, counts],
            )
        totals = counts.numpy()[:count].sum(axis=0, dtype=np.int64)
        return RayCounts(
            traced_pixels=int(count),
            shadow=int(totals[0] + totals[1]),
            reflection=int(totals[2]),
            refraction=int(totals[3]),
        )
