"""The renderer as a library: a scene in, frames out, every stage timed.

``Renderer`` owns everything that lives across frames (the device scene and its BVH,
the stage objects, the frame buffers); each call to ``render`` takes all per-frame
state explicitly (camera, time) and returns a ``Frame`` with the colour, the
G-buffer AOVs and per-stage statistics.  There are no module-level globals; the clock
is injected.

Pipeline stages, in order (one subpackage each): scene -> raster -> lighting ->
focus -> trace -> compose -> post.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import warp as wp

from .compose import Compositor
from .errors import RenderSettingsError
from .focus import SHAPES, FocusRegion, FocusRegionBuilder, FocusWindow
from .lighting.deferred import DeferredLighting
from .parallel import Launcher
from .post.postprocess import TONEMAPS, PostProcess
from .raster.gbuffer import GBuffer
from .raster.raycast import RayCaster
from .raster.rasterizer import Rasterizer
from .runtime import resolve_device
from .scene.device import DeviceScene, make_camera_gpu
from .scene.model import Camera, Scene
from .timing import Clock, StageTimer, perf_clock
from .trace.tracer import Tracer, TraceSettings

PRIMARY_PATHS = ("raster", "raycast")
MODES = ("raster", "full", "hybrid")


@dataclass
class RenderSettings:
    """Everything that stays fixed while frames are rendered.

    ``mode``: "raster" (deferred shading only), "full" (every pixel ray traced) or
    "hybrid" (ray traced inside the focus window, raster outside).  ``window_*`` give
    the default focus window (a frame may pass its own).  ``exposure_ev``: None =
    automatic (key 0.18 over the log-average luminance), otherwise a fixed exposure
    in stops.  ``threads``: host threads per pass (None = one per core on the CPU,
    1 on CUDA).
    """

    width: int = 640
    height: int = 480
    device: str = "cpu"
    mode: str = "hybrid"
    primary: str = "raster"
    window_fraction: float = 0.25
    window_shape: str = "circle"
    feather_px: float = 16.0
    max_depth: int = 3
    shadow_samples: int = 1
    exposure_ev: float | None = None
    tonemap: str = "aces"
    antialias: bool = True
    threads: int | None = None

    def validate(self) -> None:
        """Raise ``RenderSettingsError`` for values that cannot be honoured."""
        if not (1 <= self.width <= 16384 and 1 <= self.height <= 16384):
            raise RenderSettingsError(f"image size {self.width}x{self.height} is out of range (1..16384)")
        if self.mode not in MODES:
            raise RenderSettingsError(f"mode {self.mode!r} is not one of {', '.join(MODES)}")
        if self.window_shape not in SHAPES:
            raise RenderSettingsError(f"window shape {self.window_shape!r} is not one of {', '.join(SHAPES)}")
        if not 0.0 <= self.window_fraction <= 1.0:
            raise RenderSettingsError(
                f"window fraction must be in [0, 1] (share of the screen area), got {self.window_fraction}"
            )
        if not self.feather_px >= 0.0:
            raise RenderSettingsError(f"feather must be >= 0 pixels, got {self.feather_px}")
        if self.max_depth < 0:
            raise RenderSettingsError(f"max depth must be >= 0, got {self.max_depth}")
        if self.shadow_samples < 1:
            raise RenderSettingsError(f"shadow samples must be >= 1, got {self.shadow_samples}")
        if self.primary not in PRIMARY_PATHS:
            raise RenderSettingsError(f"primary path {self.primary!r} is not one of {', '.join(PRIMARY_PATHS)}")
        if self.tonemap not in TONEMAPS:
            raise RenderSettingsError(f"tone mapping {self.tonemap!r} is not one of {', '.join(TONEMAPS)}")
        if self.threads is not None and self.threads < 1:
            raise RenderSettingsError(f"threads must be >= 1, got {self.threads}")


@dataclass
class Frame:
    """One rendered frame.

    ``color``: (H, W, 3) float32 linear radiance before exposure and tone mapping.
    ``visibility``: (H, W, L) float32 transmittance luminance to each light, NaN where
    not traced.
    ``image``: (H, W, 3) uint8 sRGB after exposure, tone mapping and anti-aliasing.
    ``stats``: JSON-ready dict (ms per stage, triangles, resolution, device, ...).
    ``gbuffer`` is the renderer's own buffer: valid until its next ``render``.
    """

    color: np.ndarray
    image: np.ndarray
    gbuffer: GBuffer
    visibility: np.ndarray
    stats: dict[str, Any] = field(default_factory=dict)

    def aovs(self) -> dict[str, np.ndarray]:
        """The AOV contract: depth, position, normal, albedo from the G-buffer,
        color (linear, before tone mapping) and visibility."""
        out = self.gbuffer.aovs()
        out["color"] = self.color.astype(np.float32)
        out["visibility"] = self.visibility
        return out


class Renderer:
    """Renders frames of one scene on one device at one resolution."""

    def __init__(self, scene: Scene, settings: RenderSettings | None = None, clock: Clock = perf_clock) -> None:
        """Upload ``scene`` and build the BVH; ``clock`` times every stage."""
        self.settings = settings or RenderSettings()
        self.settings.validate()
        self.clock = clock
        self.device = resolve_device(self.settings.device)
        self._sync = (lambda: wp.synchronize_device(self.device)) if self.device.is_cuda else None
        self.setup_ms: dict[str, float] = {}
        timer = self._timer()
        self.device_scene = DeviceScene(scene, self.device, timer)
        self.setup_ms = dict(timer.stages_ms)
        self.launcher = Launcher(self.device, self.settings.threads)
        primary_cls = Rasterizer if self.settings.primary == "raster" else RayCaster
        self.primary = primary_cls(self.launcher)
        self.lighting = DeferredLighting(self.launcher)
        self.post = PostProcess(self.launcher)
        s = self.settings
        w, h = s.width, s.height
        self.gbuffer = GBuffer.allocate(w, h, self.device)
        self.raster_color = wp.zeros((h, w), dtype=wp.vec3, device=self.device)
        lights = len(scene.lights)
        self.visibility = wp.full((h, w, lights), value=float("nan"), dtype=wp.float32, device=self.device)
        self.tracer: Tracer | None = None
        if s.mode != "raster":
            trace_settings = TraceSettings(max_depth=s.max_depth, shadow_samples=s.shadow_samples)
            self.tracer = Tracer(self.launcher, self.device_scene.features, trace_settings)
            self.traced_color = wp.zeros((h, w), dtype=wp.vec3, device=self.device)
            self.focus = FocusRegionBuilder(self.launcher, w, h)
            self.compositor = Compositor(self.launcher)
            self.color = (
                wp.zeros((h, w), dtype=wp.vec3, device=self.device) if s.mode == "hybrid" else self.traced_color
            )
        else:
            self.color = self.raster_color

    @property
    def scene(self) -> Scene:
        """The scene currently on the device."""
        return self.device_scene.scene

    def _timer(self) -> StageTimer:
        return StageTimer(clock=self.clock, sync=self._sync)

    def close(self) -> None:
        """Release the worker threads."""
        self.launcher.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def warm_up(self, camera: Camera) -> float:
        """Render and discard one frame so every kernel this scene needs is compiled
        and loaded; the time goes to ``setup_ms["warm_up"]`` (not to a frame's stages)
        and is returned in ms."""
        start = self.clock()
        self.render(camera)
        elapsed = (self.clock() - start) * 1000.0
        self.setup_ms["warm_up"] = elapsed
        return elapsed

    def update_scene(self, scene: Scene) -> float:
        """Swap in the same scene at another time (same topology): copy the moved
        points and refit the BVH.  Returns the milliseconds it took."""
        timer = self._timer()
        with timer.stage("refit"):
            self.device_scene.update(scene)
        return timer.total_ms

    def default_window(self, gaze: tuple[float, float] = (0.5, 0.5)) -> FocusWindow:
        """The settings' focus window centred on ``gaze`` (normalised, top-left origin)."""
        s = self.settings
        return FocusWindow(gaze=gaze, fraction=s.window_fraction, shape=s.window_shape, feather_px=s.feather_px)

    def render(self, camera: Camera, window: FocusWindow | None = None) -> Frame:
        """Render one frame through ``camera``.

        ``window`` is this frame's focus window (hybrid mode; default: the settings'
        window at the screen centre).  It is ignored in raster and full modes.
        """
        s = self.settings
        timer = self._timer()
        cam = make_camera_gpu(camera, s.width, s.height)
        self.gbuffer.clear()
        self.primary.render(self.device_scene, cam, self.gbuffer, timer)
        trace_stats: dict[str, Any] = {}
        region: FocusRegion | None = None
        if s.mode == "full":
            region = self.focus.full_screen()
        elif s.mode == "hybrid":
            region = self.focus.build(window or self.default_window(), timer)
        if s.mode != "full":
            # hybrid: the window's interior (weight 1) is replaced by the traced layer
            skip = region.weight if region is not None else None
            self.lighting.shade(self.device_scene, cam, self.gbuffer, self.raster_color, timer, skip_weight=skip)
        if region is not None:
            trace_stats = self._trace(cam, region, window or self.default_window(), timer)
        image = self.post.run(self.color, s.exposure_ev, s.tonemap, s.antialias, timer, self.gbuffer.triangle_id)
        with timer.stage("readback"):
            color = self.color.numpy().astype(np.float32)
            visibility = self.visibility.numpy().astype(np.float32)
        stats = {
            "scene": self.scene.path,
            "camera": camera.name,
            "time": self.scene.time,
            "device": str(self.device.alias),
            "mode": s.mode,
            "primary": s.primary,
            "resolution": [s.width, s.height],
            "triangles": self.scene.triangle_count,
            "threads": self.launcher.threads,
            "effects": self.device_scene.features.names(),
            "setup_ms": dict(self.setup_ms),
            "stages_ms": dict(timer.stages_ms),
            "frame_ms": timer.total_ms,
            "exposure_ev": self.post.last_exposure_ev,
            **trace_stats,
        }
        return Frame(color=color, image=image, gbuffer=self.gbuffer, visibility=visibility, stats=stats)

    def _trace(self, cam: Any, region: FocusRegion, window: FocusWindow, timer: StageTimer) -> dict[str, Any]:
        """Trace ``region`` (every pixel in full mode) and compose it over the raster
        image; returns the frame's tracing statistics."""
        assert self.tracer is not None
        full = self.settings.mode == "full"
        self.visibility.fill_(float("nan"))
        counts = self.tracer.trace(
            self.device_scene, cam, self.gbuffer, region.pixels, region.count, self.traced_color, self.visibility, timer
        )
        if not full:
            self.compositor.blend(self.raster_color, self.traced_color, region.weight, self.color, timer)
        layout = region.layout
        return {
            "rays": counts.to_dict(),
            "window": {
                "gaze": list(window.gaze) if not full else None,
                "fraction": 1.0 if full else window.fraction,
                "shape": layout.shape,
                "centre_px": [layout.cx, layout.cy],
                "feather_px": layout.feather_px,
                "pixels": region.count,
                "covered_fraction": layout.covered_fraction,
            },
        }
