"""Timed renders of each configuration and their error against the reference.

One ``DeviceScene`` (upload and BVH once) serves every renderer of a scene.  The
reference is ``--mode full`` supersampled (``reference_spp``, 16 by default); its
automatic exposure is metered once and every configuration renders at that fixed
exposure, so error comparisons never mix exposures.  A configuration's time is the
median wall time of ``repeats`` renders after a warm-up frame (the renders run one at
a time, never in parallel), per stage too.  The error compares its tone-mapped sRGB
image and linear radiance with the reference's (``metrics.evaluate``): FLIP mean,
foveated FLIP around the gaze, FLIP inside and outside the foveal window (the window of
``fovea_fraction`` at the gaze, the same region for every method), and PSNR.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
import warp as wp

from ..focus import FocusWindow
from ..metrics import ErrorReport, ViewingSetup, evaluate, layout_mask
from ..parallel import Launcher
from ..post.postprocess import PostProcess
from ..renderer import Renderer, RenderSettings
from ..scene.device import DeviceScene
from ..scene.model import Camera, Scene
from ..timing import StageTimer
from .configs import Config


@dataclass
class Measurement:
    """A configuration's median time (ms, whole frame and per stage) and its error."""

    config: Config
    ms: float
    stages_ms: dict[str, float]
    error: ErrorReport
    extra: dict[str, Any] = field(default_factory=dict)


def _median_stages(runs: list[dict[str, float]]) -> dict[str, float]:
    names = sorted({k for r in runs for k in r})
    return {k: statistics.median(r.get(k, 0.0) for r in runs) for k in names}


class SceneSweep:
    """Measures the configurations of one scene seen by one camera looking at ``gaze``."""

    def __init__(
        self,
        scene: Scene,
        camera: Camera,
        base: RenderSettings,
        gaze: tuple[float, float],
        repeats: int = 3,
        reference_spp: int = 16,
        fovea_fraction: float = 0.1,
        viewing: ViewingSetup | None = None,
    ) -> None:
        """Upload ``scene`` once; ``base`` gives the size, device, threads, tracing and
        post settings every configuration shares."""
        self.scene = scene
        self.camera = camera
        self.base = base
        self.gaze = gaze
        self.repeats = repeats
        self.reference_spp = reference_spp
        self.viewing = viewing or ViewingSetup()
        self.device_scene = DeviceScene(scene, base.device, indirect=base.indirect)
        self.fovea = layout_mask(FocusWindow(gaze, fovea_fraction, base.window_shape).layout(base.width, base.height))
        self.exposure_ev: float | None = None
        self._reference: tuple[np.ndarray, np.ndarray] | None = None

    def _settings(self, **changes: Any) -> RenderSettings:
        values = {**self.base.__dict__, **changes}
        return RenderSettings(**values)

    def reference(self) -> tuple[np.ndarray, np.ndarray]:
        """The reference's linear radiance and sRGB image; meters the sweep's exposure."""
        if self._reference is None:
            settings = self._settings(mode="full", spp=self.reference_spp, exposure_ev=self.base.exposure_ev)
            with Renderer(self.device_scene, settings) as r:
                frame = r.render(self.camera)
            self.exposure_ev = float(frame.stats["exposure_ev"])
            self._reference = (frame.color.copy(), frame.image.copy())
        return self._reference

    def reference_noise(self, spp: int) -> ErrorReport:
        """The reference's own noise: its error against a render at ``spp`` samples."""
        linear, srgb = self.reference()
        settings = self._settings(mode="full", spp=spp, exposure_ev=self.exposure_ev)
        with Renderer(self.device_scene, settings) as r:
            frame = r.render(self.camera)
        return evaluate(srgb, frame.image, linear, frame.color, self.gaze, self.fovea, self.viewing)

    def measure(self, config: Config) -> Measurement:
        """Time ``config`` and measure its error."""
        linear_ref, srgb_ref = self.reference()
        if config.method == "full_lowres":
            return self._measure_lowres(config, linear_ref, srgb_ref)
        mode = {"raster": "raster", "full": "full"}.get(config.method, "hybrid")
        settings = self._settings(
            mode=mode, window_fraction=config.fraction or self.base.window_fraction, fovea_spp=config.spp
        )
        settings.exposure_ev = self.exposure_ev
        gaze = (0.5, 0.5) if config.method == "hybrid_centre" else self.gaze
        with Renderer(self.device_scene, settings) as r:
            window = r.default_window(gaze) if mode == "hybrid" else None
            r.warm_up(self.camera)
            times, stages = [], []
            for _ in range(self.repeats):
                start = time.perf_counter()
                frame = r.render(self.camera, window)
                times.append((time.perf_counter() - start) * 1000.0)
                stages.append(frame.stats["stages_ms"])
            error = evaluate(srgb_ref, frame.image, linear_ref, frame.color, self.gaze, self.fovea, self.viewing)
        return Measurement(config, statistics.median(times), _median_stages(stages), error)

    def _measure_lowres(self, config: Config, linear_ref: np.ndarray, srgb_ref: np.ndarray) -> Measurement:
        """Full ray tracing at ``config.scale`` of the size, upscaled bilinearly in linear
        radiance, then exposed and tone mapped at the screen size (stages "upscale": the
        resize and upload, "upscale_post": the full-size exposure, tone map and FXAA)."""
        w, h = self.base.width, self.base.height
        lw, lh = max(1, round(w * config.scale)), max(1, round(h * config.scale))
        settings = self._settings(mode="full", width=lw, height=lh)
        settings.exposure_ev = self.exposure_ev
        with Renderer(self.device_scene, settings) as r, Launcher(r.device, r.launcher.threads) as launcher:
            post = PostProcess(launcher)
            r.warm_up(self.camera)
            times, stages = [], []
            for _ in range(self.repeats):
                start = time.perf_counter()
                frame = r.render(self.camera)
                timer = StageTimer()
                with timer.stage("upscale"):
                    color = cv2.resize(frame.color, (w, h), interpolation=cv2.INTER_LINEAR)
                    device_color = wp.array(color, dtype=wp.vec3, device=r.device)
                with timer.stage("upscale_post"):
                    image = post.process(
                        device_color, self.exposure_ev, self.base.tonemap, self.base.antialias, StageTimer()
                    ).numpy()
                times.append((time.perf_counter() - start) * 1000.0)
                stages.append({**frame.stats["stages_ms"], **timer.stages_ms})
            error = evaluate(srgb_ref, image, linear_ref, color, self.gaze, self.fovea, self.viewing)
        return Measurement(config, statistics.median(times), _median_stages(stages), error, {"size": [lw, lh]})
