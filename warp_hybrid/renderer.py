"""The renderer as a library: a scene in, frames out, every stage timed.

``Renderer`` owns what lives across frames (the passes, the frame buffers) and uses a
``DeviceScene`` (its own, or one the caller shares: a viewer resizes without rebuilding
the BVH); each ``render`` takes all per-frame state explicitly (camera, focus window)
and returns a ``Frame`` with the colour, the G-buffer AOVs and per-stage statistics.
There are no module-level globals; the clock is injected.

A frame runs the mode's passes in order (``core.passes``), each on the frame's
``FrameContext``: shadow maps (raster and hybrid, when on; drawn again only when the
scene moved) -> the reflection probe (raster and hybrid, when on; captured again only
when the scene changed) -> primary visibility (raster or ray cast) -> focus region (hybrid and
full) -> deferred lighting (raster and hybrid; every pixel) -> the layer behind
alpha-blended surfaces (raster and hybrid, where the scene has any; ``lighting.alpha_layer``) ->
tracing (hybrid and full; in hybrid mode under the budget guard, ``trace.guard``, when the
frame has a deadline) -> the ring's upsampling (hybrid with ``ring``;
``compose.upsample``) -> compose (hybrid) -> post.  A supersampled frame (``spp`` > 1, full
mode; ``supersample``) runs the passes before the post once per sample, each at its own
point in every pixel, accumulates them, renders the G-buffer once more at the pixel
centres and posts the average.  In a frame of one sample the passes that touch the
frame's data only through the launcher (``RenderPass.overlapped``: primary visibility,
lighting, the alpha layer, post) leave their last launch running while the next pass's
Python prepares (``Launcher.overlapping``); the others wait for it and for their own
(``Launcher.paused``).  Its stage times stay the frame's wall time, split by stage (a
wait for a launch still running is its stage's).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
import warp as wp

from .compose import Compositor
from .compose.reuse import TemporalReuse
from .compose.upsample import RingUpsampler
from .core.camera import CameraGPU, box_rows, make_camera_gpu
from .core.features import analyse_features
from .core.gbuffer import GBuffer
from .core.passes import FrameBuffers, FrameContext, RenderPass
from .core.rows import NO_ROWS, RowSpan
from .errors import ArgumentTypeError, RenderSettingsError
from .field_types import check_field_types
from .focus import SHAPES, FocusRegionBuilder, FocusWindow
from .focus.ring import RingSpec
from .focus.ring_builder import RingedFocusBuilder
from .lighting.alpha_layer import AlphaLayer
from .lighting.deferred import DeferredLighting
from .lighting.probes import PROBE_SIZE, ReflectionProbe
from .lighting.shadow_maps import DEFAULT_MAP_SIZE, MAX_MAP_SIZE, MIN_MAP_SIZE, ShadowMaps
from .memory import check_memory
from .parallel import Launcher, default_thread_count
from .post.postprocess import TONEMAPS, PostProcess
from .primary import PrimaryVisibility, Rasterizer, RayCaster
from .runtime import resolve_device
from .scene.camera_check import check_camera
from .scene.device import DeviceScene
from .scene.model import Camera, Scene
from .supersample import MAX_SPP, SampleAccumulator, sample_offsets, sample_step
from .timing import Clock, StageTimer, perf_clock
from .trace import RayTally, Tracer, TraceSettings
from .trace.fovea import FoveaSampler
from .trace.guard import GuardedTrace

PRIMARY_PATHS = ("raster", "raycast")


def _camera_values(camera: object, width: int, height: int) -> tuple | None:
    """Everything ``make_camera_gpu`` reads from ``camera`` for a ``width`` x ``height``
    image (and ``check_camera`` checks), as a key; None for anything but a ``Camera``
    with a numpy transform."""
    if not isinstance(camera, Camera) or not isinstance(camera.cam_to_world, np.ndarray):
        return None
    m = camera.cam_to_world
    return (
        camera.focal_length,
        camera.horizontal_aperture,
        camera.near,
        camera.far,
        m.dtype.str,
        m.shape,
        m.tobytes(),
        width,
        height,
    )


class _ViewKey(NamedTuple):
    """What a raster layer was drawn for (``Renderer._still_view_key``): the device scene,
    its ``content_version``, the frame buffers and the camera's parameters."""

    scene: int
    content: int
    buffers: int
    view: tuple


#: The passes that draw the raster layer (kept across frames of a still view, ``cache_raster``).
_RASTER_LAYER_PASSES = (PrimaryVisibility, DeferredLighting, AlphaLayer)
MODES = ("raster", "full", "hybrid")
#: The largest fixed exposure, in stops either way: 2^64 scales any radiance the scene
#: holds without overflowing float32 (2^1000000 is not even a float64).
MAX_EXPOSURE_EV = 64.0


@dataclass
class RenderSettings:
    """Everything that stays fixed while frames are rendered.

    ``mode``: "raster" (deferred shading only), "full" (every pixel ray traced) or
    "hybrid" (ray traced inside the focus window, raster outside).  ``window_*`` give
    the default focus window (a frame may pass its own).  ``exposure_ev``: None =
    automatic (key 0.18 over the log-average luminance), otherwise a fixed exposure
    in stops.  ``threads``: host threads per pass (None = one per core on the CPU,
    1 on CUDA).  ``spp``: samples per pixel, 1..``MAX_SPP``: 1 samples each pixel's
    centre; N > 1 (full mode only) averages N sub-frames at stratified jittered points
    (``supersample``: box filter), drawn from ``sample_seed``.  ``fovea_spp``: samples
    per pixel inside the focus window (hybrid mode only; ``trace.fovea``): N > 1 traces
    the window with the same N-sample pattern, the rest of the frame stays at one.
    ``shadow_maps``: shadow the raster layer (deferred lighting, raster and hybrid
    modes; the traced window has its own shadow rays) with every light's shadow map
    (``lighting.shadow_maps``), ``shadow_map_size`` texels square per face (a cube map
    of six faces per sphere/rect/disk light, one face per distant light); off by default.
    ``indirect``: both layers add the lights' interreflected light, one estimate per
    scene from their emitted power (``lighting.indirect``), to the diffuse ambient, so
    shadowed surfaces are not black in a scene without a dome; off by default.
    ``ring``: the mid-resolution ring (hybrid mode; ``focus.ring``): around the window,
    out to ``ring_scale`` x its half extents, the effects are traced at every
    ``ring_step``-th pixel in x and y and upsampled with the G-buffer as the guide
    (``compose.upsample``); off by default (ignored in raster and full modes).
    ``probes``: the raster layer's glossy ambient (mirrors, metals, glass outside the
    traced window) reads a reflection probe, the scene captured by the rasterizer from
    the camera's position at the first frame and again whenever the scene changes, with
    the dome where it saw background (``lighting.probes``), instead of the dome alone
    (black without one); raster and hybrid modes; off by default.
    ``reuse``: temporal reuse (hybrid mode; ``compose.reuse``): where the window no
    longer traces, the last frames' traced values reprojected through the G-buffer,
    fading to the raster layer over a few frames; off by default.
    ``cache_raster``: keep the raster layer (the G-buffer, its deferred lighting and the
    layer behind blended surfaces) of the last frame when neither the camera nor the
    scene changed since (a gaze replay over a still view), and draw only what depends on
    the window (tracing, compose, post); the image is the same bit for bit.  Where the
    scene update before the frame moved geometry alone (``DeviceScene.moved``) within a
    box in front of the camera, only the rows that box projects to are drawn again (the
    stats' ``raster_rows``), without shadow maps, the probe or alpha-blended surfaces,
    whose pixels depend on more than their own surface.  Off by default (every frame pays
    its whole cost, as benchmarks of one frame's cost need); the replay and viewer
    commands turn it on.
    ``cache_shadows``: with ``cache_raster``, the kept frames also keep the primary hits'
    shadows the view has traced (``trace.shadow_cache``: a pixel the window covered in an
    earlier frame of the view sends no primary shadow ray again); the image is the same
    bit for bit.  On by default; off, every window pixel traces its shadows every frame.
    ``wide_bvh``: the tracer and the ray-cast primaries query 4-wide copies of the BVHs
    (``scene.device.wide_bvh``: the same answers, 2-3x faster on the CPU); None
    (default): on the CPU, not on CUDA, where it is refused; False keeps Warp's own
    queries everywhere (benchmarks compare the two).
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
    spp: int = 1
    fovea_spp: int = 1
    sample_seed: int = 0
    shadow_maps: bool = False
    shadow_map_size: int = DEFAULT_MAP_SIZE
    indirect: bool = False
    ring: bool = False
    ring_scale: float = RingSpec.scale
    ring_step: int = RingSpec.step
    probes: bool = False
    reuse: bool = False
    cache_raster: bool = False
    cache_shadows: bool = True
    wide_bvh: bool | None = None

    @property
    def ring_spec(self) -> RingSpec | None:
        """The ring's sizing where a frame has one (``ring`` on, hybrid mode), else None."""
        return RingSpec(self.ring_scale, self.ring_step) if self.ring and self.mode == "hybrid" else None

    def validate(self) -> None:
        """Raise ``RenderSettingsError`` for values that cannot be honoured (an
        ``ArgumentTypeError`` naming the field for a value of the wrong type)."""
        check_field_types(self)
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
        if not 0.0 <= self.feather_px < math.inf:
            raise RenderSettingsError(f"feather must be >= 0 pixels and finite, got {self.feather_px}")
        if self.exposure_ev is not None and not -MAX_EXPOSURE_EV <= self.exposure_ev <= MAX_EXPOSURE_EV:
            raise RenderSettingsError(
                f"exposure must be 'auto' (None) or a number of stops in [-{MAX_EXPOSURE_EV:g}, {MAX_EXPOSURE_EV:g}], "
                f"got {self.exposure_ev}"
            )
        if self.max_depth < 0:
            raise RenderSettingsError(f"max depth must be >= 0, got {self.max_depth}")
        if self.shadow_samples < 1:
            raise RenderSettingsError(f"shadow samples must be >= 1, got {self.shadow_samples}")
        if self.primary not in PRIMARY_PATHS:
            raise RenderSettingsError(f"primary path {self.primary!r} is not one of {', '.join(PRIMARY_PATHS)}")
        if self.tonemap not in TONEMAPS:
            raise RenderSettingsError(f"tone mapping {self.tonemap!r} is not one of {', '.join(TONEMAPS)}")
        if not MIN_MAP_SIZE <= self.shadow_map_size <= MAX_MAP_SIZE:
            raise RenderSettingsError(
                f"shadow map size must be in {MIN_MAP_SIZE}..{MAX_MAP_SIZE} texels per face, got {self.shadow_map_size}"
            )
        RingSpec(self.ring_scale, self.ring_step).validate()
        if self.threads is not None and self.threads < 1:
            raise RenderSettingsError(f"threads must be >= 1, got {self.threads}")
        for name, what, mode in (
            ("spp", "samples per pixel", "full"),
            ("fovea_spp", "window samples per pixel", "hybrid"),
        ):
            value = getattr(self, name)
            if not 1 <= value <= MAX_SPP:
                raise RenderSettingsError(f"{what} must be in 1..{MAX_SPP}, got {value}")
            if value > 1 and self.mode != mode:
                raise RenderSettingsError(f"{value} {what} need mode {mode!r}, got mode {self.mode!r}")


@dataclass
class Frame:
    """One rendered frame.

    ``color``: (H, W, 3) float32 linear radiance before exposure and tone mapping (the
    mean over the samples of a supersampled frame).
    ``visibility``: (H, W, L) float32 transmittance luminance to each light, NaN where
    not traced (supersampled: the mean over the samples that traced it).  The G-buffer
    AOVs are the pixel centres' whatever the samples per pixel.
    ``image``: (H, W, 3) uint8 sRGB after exposure, tone mapping and anti-aliasing.
    ``stats``: JSON-ready dict (ms per stage, triangles, resolution, device, ...).
    ``origin``: the scene's local frame (``Scene.origin``, float64), which the device's
    positions are relative to.
    ``gbuffer`` is the renderer's own buffer: valid until its next ``render``; so are
    ``color`` and ``visibility`` when the frame was rendered without host copies
    (``render(..., host_copies=False)``), read from the device when first used.
    """

    image: np.ndarray
    gbuffer: GBuffer
    buffers: FrameBuffers
    stats: dict[str, Any] = field(default_factory=dict)
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _color: np.ndarray | None = None
    _visibility: np.ndarray | None = None

    @property
    def color(self) -> np.ndarray:
        """Linear radiance (H, W, 3) float32."""
        if self._color is None:
            self.copy_to_host()
        return self._color

    @property
    def visibility(self) -> np.ndarray:
        """Per-light transmittance luminance (H, W, L) float32, NaN where not traced."""
        if self._visibility is None:
            self.copy_to_host()
        return self._visibility

    def copy_to_host(self) -> None:
        """Read ``color`` and ``visibility`` from the device now (they then outlive the
        renderer's next frame)."""
        self._color = self.buffers.color.numpy().astype(np.float32)
        self._visibility = self.buffers.visibility.numpy().astype(np.float32)

    def aovs(self) -> dict[str, np.ndarray]:
        """The AOV contract: depth, position (world space: the local frame's hit point
        plus ``origin``, added in float64), normal, albedo from the G-buffer, color
        (linear, before tone mapping) and visibility."""
        out = self.gbuffer.aovs()
        out["position"] = (out["position"].astype(np.float64) + self.origin).astype(np.float32)
        out["color"] = self.color
        out["visibility"] = self.visibility
        return out


class Renderer:
    """Renders frames of one scene on one device at one resolution (``resize`` changes it)."""

    def __init__(
        self, scene: Scene | DeviceScene, settings: RenderSettings | None = None, clock: Clock = perf_clock
    ) -> None:
        """Upload ``scene`` and build its BVH, or use a ``DeviceScene`` the caller owns
        (on the settings' device); ``clock`` times every stage."""
        if settings is not None and not isinstance(settings, RenderSettings):
            raise ArgumentTypeError(f"settings must be a RenderSettings or None, got {type(settings).__name__}")
        if not isinstance(scene, (Scene, DeviceScene)):
            raise ArgumentTypeError(f"scene must be a Scene or a DeviceScene, got {type(scene).__name__} {scene!r}")
        self.settings = settings or RenderSettings()
        self.settings.validate()
        self.clock = clock
        self.device = resolve_device(self.settings.device)
        self._sync = (lambda: wp.synchronize_device(self.device)) if self.device.is_cuda else None
        self.setup_ms: dict[str, float] = {}
        host_scene = scene.scene if isinstance(scene, DeviceScene) else scene
        upload = scene if isinstance(scene, Scene) else None
        self._check_memory(self.settings.width, self.settings.height, host_scene, upload)
        if isinstance(scene, DeviceScene):
            if scene.device != self.device:
                raise RenderSettingsError(f"the device scene is on {scene.device.alias}, not {self.device.alias}")
            if scene.indirect != self.settings.indirect:
                raise RenderSettingsError(
                    f"the device scene was built with indirect={scene.indirect}, "
                    f"but the settings ask for indirect={self.settings.indirect}"
                )
            self.device_scene = scene
        else:
            timer = self.new_timer()
            self.device_scene = DeviceScene(scene, self.device, timer, indirect=self.settings.indirect)
            self.setup_ms = dict(timer.stages_ms)
        self.launcher = Launcher(self.device, self.settings.threads)
        self.passes = self._make_passes()
        self.buffers = self._make_buffers(self.settings.width, self.settings.height)
        self._accumulator = SampleAccumulator(self.launcher)
        self._still_view: _ViewKey | None = None  # what the raster layer now in the buffers was drawn for
        self._camera: tuple[tuple, CameraGPU] | None = None  # the last camera's values and kernel camera
        self._set_scene()

    def _check_memory(self, width: int, height: int, scene: Scene, upload: Scene | None) -> None:
        """Refuse, before allocating, a size whose memory estimate does not fit the
        device (``memory.check_memory``; ``scene``: the one to draw, ``upload``: the
        scene still to upload, or None)."""
        s = self.settings
        threads = s.threads if s.threads is not None else default_thread_count(self.device)
        maps = s.shadow_map_size if s.shadow_maps and s.mode != "full" else 0
        probe = PROBE_SIZE if s.probes and s.mode != "full" else 0
        lights = len(scene.lights)
        behind = s.mode != "full" and analyse_features(scene).blending
        points = len(scene.points)
        check_memory(
            width,
            height,
            lights,
            threads,
            self.device,
            upload,
            spp=s.spp,
            fovea_spp=s.fovea_spp,
            shadow_maps=maps,
            points=points,
            alpha_layer=behind,
            probe=probe,
            reuse=s.reuse and s.mode == "hybrid",
        )

    def _make_passes(self) -> list[RenderPass]:
        """The mode's passes, in frame order (the shadow maps first and the reflection
        probe next, where the raster layer is shaded and they are on)."""
        s = self.settings
        primary = Rasterizer(self.launcher) if s.primary == "raster" else RayCaster(self.launcher, s.wide_bvh)
        passes: list[RenderPass] = [primary]
        maps = ShadowMaps(self.launcher, s.shadow_map_size) if s.shadow_maps and s.mode != "full" else None
        probe = ReflectionProbe(self.launcher, maps) if s.probes and s.mode != "full" else None
        if probe is not None:
            passes.insert(0, probe)
        if maps is not None:
            passes.insert(0, maps)
        # (automatic exposure: the lighting row loop meters the raster layer as it writes it)
        meter = s.exposure_ev is None
        if s.mode == "raster":
            # (no traced ray leaves a raster frame's surfaces: only the shadow maps' lookups
            # read their geometric normals)
            primary.geometric_normals = maps is not None
            passes += [DeferredLighting(self.launcher, maps, probe, meter), AlphaLayer(self.launcher, maps, probe)]
        else:
            ring = s.ring_spec
            if ring is None:
                focus = FocusRegionBuilder(self.launcher, s.width, s.height)
            else:
                focus = RingedFocusBuilder(self.launcher, s.width, s.height, ring)
            tracer = Tracer(
                self.launcher,
                TraceSettings(
                    max_depth=s.max_depth,
                    shadow_samples=s.shadow_samples,
                    wide_bvh=s.wide_bvh,
                    keep_shadows=s.cache_shadows,
                ),
            )
            passes.append(focus)
            if s.mode == "full":
                passes.append(tracer)
            else:
                lighting = DeferredLighting(self.launcher, maps, probe, meter)
                if s.fovea_spp > 1:
                    trace: RenderPass = FoveaSampler(tracer, s.fovea_spp, s.sample_seed)
                else:
                    trace = GuardedTrace(tracer, focus)
                passes += [lighting, AlphaLayer(self.launcher, maps, probe), trace]
                if ring is not None:
                    passes.append(RingUpsampler(self.launcher))
                passes.append(Compositor(self.launcher))
                if s.reuse:
                    passes.append(TemporalReuse(self.launcher))
        passes.append(PostProcess(self.launcher, s.exposure_ev, s.tonemap, s.antialias))
        return passes

    def _make_buffers(self, width: int, height: int) -> FrameBuffers:
        """Frame buffers for this size and the scene's lights; ``color`` is the layer
        the mode shows (raster, traced, or the composed one), ``metered`` the one
        automatic exposure is metered on (the raster layer in raster and hybrid modes,
        so a hybrid frame's exposure does not depend on its window)."""
        buffers = FrameBuffers(width, height, len(self.scene.lights), self.device)
        if self.settings.mode == "raster":
            buffers.color = buffers.raster_color
        elif self.settings.mode == "full":
            buffers.color = buffers.traced_color
        buffers.metered = buffers.traced_color if self.settings.mode == "full" else buffers.raster_color
        return buffers

    def _set_scene(self) -> None:
        for p in self.passes:
            p.set_scene(self.device_scene)

    @property
    def scene(self) -> Scene:
        """The scene currently on the device."""
        return self.device_scene.scene

    @property
    def tracer(self) -> Tracer | None:
        """The tracer (None in raster mode)."""
        for p in self.passes:
            if isinstance(p, (GuardedTrace, FoveaSampler)):
                return p.tracer
            if isinstance(p, Tracer):
                return p
        return None

    def new_timer(self) -> StageTimer:
        """A stage timer on the renderer's clock that synchronises its device before
        each reading (so a stage's time covers its launched work)."""
        return StageTimer(clock=self.clock, sync=self._sync)

    def close(self) -> None:
        """Release the worker threads."""
        self.launcher.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def resize(self, width: int, height: int) -> None:
        """Render ``width`` x ``height`` frames from now on (the scene and its BVH stay)."""
        before = (self.settings.width, self.settings.height)
        self.settings.width, self.settings.height = width, height
        try:
            self.settings.validate()
            self._check_memory(width, height, self.scene, None)
        except RenderSettingsError:  # refused: the renderer keeps its size
            self.settings.width, self.settings.height = before
            raise
        for p in self.passes:
            p.resize(width, height)
        self.buffers = self._make_buffers(width, height)

    def warm_up(self, camera: Camera) -> float:
        """Render and discard one frame so every kernel this scene needs is compiled
        and loaded (a supersampled one with two samples: every kernel runs by then); the
        time goes to ``setup_ms["warm_up"]`` (not to a frame's stages) and is returned
        in ms."""
        start = self.clock()
        self._render(camera, None, None, True, min(self.settings.spp, 2))
        elapsed = (self.clock() - start) * 1000.0
        self.setup_ms["warm_up"] = elapsed
        return elapsed

    def update_scene(self, scene: Scene) -> float:
        """Swap in the same scene at another time (same topology): copy what moved,
        refit the BVH, re-upload what changed (lights, materials, the dome) and let
        every pass see it.  Returns the milliseconds it took."""
        timer = self.new_timer()
        with timer.stage("refit"):
            self.device_scene.update(scene)
            self._set_scene()
            if not self.buffers.fits(self.settings.width, self.settings.height, len(scene.lights)):
                self.buffers = self._make_buffers(self.settings.width, self.settings.height)
        return timer.total_ms

    def default_window(self, gaze: tuple[float, float] = (0.5, 0.5)) -> FocusWindow:
        """The settings' focus window centred on ``gaze`` (normalised, top-left origin)."""
        s = self.settings
        return FocusWindow(gaze=gaze, fraction=s.window_fraction, shape=s.window_shape, feather_px=s.feather_px)

    def render(
        self,
        camera: Camera,
        window: FocusWindow | None = None,
        trace_deadline: float | None = None,
        host_copies: bool = True,
    ) -> Frame:
        """Render one frame through ``camera``.

        ``window`` is this frame's focus window (hybrid mode; default: the settings'
        window at the screen centre).  It is ignored in raster and full modes.
        ``trace_deadline`` (hybrid mode): a reading of the renderer's clock (seconds) by
        which tracing must stop; the window is then traced outward in rings until then
        (``trace.guard``), and the stats say how much was traced.  ``host_copies``: copy
        ``color`` and ``visibility`` to the host within the frame (False: only the
        image; they are read from the device on first use, until the next ``render``).
        With ``spp`` > 1 the frame's stages sum over its samples and the ray counts
        cover them all (``traced_pixels`` is spp x the pixels).
        """
        return self._render(camera, window, trace_deadline, host_copies, self.settings.spp)

    def _render(
        self, camera: Camera, window: FocusWindow | None, trace_deadline: float | None, host_copies: bool, spp: int
    ) -> Frame:
        """``render`` with ``spp`` samples per pixel."""
        self.launcher.wake()  # (the band threads wake while the frame is set up)
        camera_gpu = self._camera_gpu(camera)
        if window is not None and not isinstance(window, FocusWindow):
            raise ArgumentTypeError(f"window must be a FocusWindow or None, got {type(window).__name__} {window!r}")
        s = self.settings
        if trace_deadline is not None and s.fovea_spp > 1:
            raise RenderSettingsError(
                "a supersampled window (fovea_spp > 1) has no budget guard: pass no trace deadline"
            )
        if s.mode == "hybrid":
            window = window or self.default_window()
        else:
            window = None
        frame = FrameContext(
            camera=camera_gpu,
            timer=self.new_timer(),
            buffers=self.buffers,
            window=window,
            trace_deadline=trace_deadline if s.mode == "hybrid" else None,
            view=camera,
        )
        key = self._still_view_key(frame, spp)
        cached = key is not None and key == self._still_view
        frame.raster_cached = cached
        frame.raster_rows = None if cached else self._moved_rows(key, frame)
        frame.changed_rows = frame.changed_cols = NO_ROWS if cached else None
        self._still_view = None  # until this frame is whole
        if spp == 1:
            # (a pass's last launch runs on while the next pass's Python prepares; the
            # others' wait: ``RenderPass.overlapped``)
            with self.launcher.overlapping(frame.timer):
                for p in self.passes:
                    if cached and isinstance(p, _RASTER_LAYER_PASSES):
                        continue
                    if p.overlapped:
                        p.execute(frame)
                    else:
                        with self.launcher.paused():
                            p.execute(frame)
                stats = self._frame_description(camera, frame, spp)  # (while the last pass runs)
        else:
            self._render_samples(camera, frame, spp)
            stats = self._frame_description(camera, frame, spp)
        self._still_view = key
        with frame.timer.stage("readback"):
            image = np.array(frame.image.numpy(), copy=True)
            rays = frame.rays.counts() if frame.rays is not None else None
            out = Frame(
                image=image,
                gbuffer=self.buffers.gbuffer,
                buffers=self.buffers,
                origin=np.asarray(self.scene.origin, dtype=np.float64),
            )
            if host_copies:
                out.copy_to_host()
        stats.update(
            stages_ms=dict(frame.timer.stages_ms),
            frame_ms=frame.timer.total_ms,
            exposure_ev=self._post.last_exposure_ev,
        )
        if frame.region is not None and rays is not None:
            stats.update(self._trace_stats(frame, rays))
        guard = self._guard.report if self._guard is not None else None
        if guard is not None:
            stats["guard"] = dataclasses.asdict(guard)
        out.stats = stats
        return out

    def _frame_description(self, camera: Camera, frame: FrameContext, spp: int) -> dict[str, Any]:
        """The stats of a frame that no pass writes: what was drawn, how and from where
        (``Frame.stats``; its times and EV None until the frame is done, its rays after)."""
        s = self.settings
        return {
            "scene": self.scene.path,
            "camera": camera.name,
            "time": self.scene.time,
            "device": str(self.device.alias),
            "mode": s.mode,
            "primary": s.primary,
            "spp": spp,
            "fovea_spp": s.fovea_spp,
            "resolution": [s.width, s.height],
            "triangles": self.scene.triangle_count,
            "threads": self.launcher.threads,
            "effects": self.device_scene.features.names(),
            "setup_ms": dict(self.setup_ms),
            "stages_ms": None,
            "frame_ms": None,
            "exposure_ev": None,
            "raster_cached": frame.raster_cached,
            "raster_rows": list(frame.raster_rows) if frame.raster_rows is not None else None,
        }

    def _camera_gpu(self, camera: Camera) -> CameraGPU:
        """``camera`` checked (``check_camera``) and made into the kernels' camera for the
        settings' size; the last frame's where ``camera`` holds the same values (a still
        view: the check and the build took 0.2 ms of a frame's Python, which runs with
        the caches cold from the kernels)."""
        s = self.settings
        key = _camera_values(camera, s.width, s.height)
        if key is not None and self._camera is not None and self._camera[0] == key:
            return self._camera[1]
        check_camera(camera)
        gpu = make_camera_gpu(camera, s.width, s.height)
        self._camera = (key, gpu) if key is not None else None
        return gpu

    def _moved_rows(self, key: _ViewKey | None, frame: FrameContext) -> RowSpan | None:
        """The only rows of the kept raster layer that the last scene update can have
        changed, where the view stood still and that update moved geometry alone
        (``DeviceScene.moved``) within a box wholly in front of the camera: the other rows
        are kept as they are.  None (draw every row) otherwise, and wherever a pixel's
        raster colour depends on more than its own surface (shadow maps, the reflection
        probe, the layer behind alpha-blended surfaces)."""
        last, ds, s = self._still_view, self.device_scene, self.settings
        moved = ds.moved
        if key is None or last is None or moved is None or s.shadow_maps or s.probes or ds.features.blending:
            return None
        if last._replace(content=key.content) != key or (last.content, key.content) != (moved.since, moved.since + 1):
            return None
        return box_rows(frame.camera, moved.lo, moved.hi)

    def _still_view_key(self, frame: FrameContext, spp: int) -> _ViewKey | None:
        """What the raster layer of ``frame`` depends on (``RenderSettings.cache_raster``):
        the device scene and what it holds (``content_version``: every update that changed
        anything drawn), the buffers and the camera; None where the layer is not kept (off,
        full mode, several samples per pixel)."""
        s = self.settings
        if not s.cache_raster or s.mode == "full" or spp > 1 or s.fovea_spp > 1:
            return None
        ds, c = self.device_scene, frame.camera
        view = (*c.origin, *c.right, *c.up, *c.forward, c.tan_x, c.tan_y, c.width, c.height, c.near, c.far)
        return _ViewKey(id(ds), ds.content_version, id(self.buffers), view)

    def _render_samples(self, camera: Camera, frame: FrameContext, spp: int) -> None:
        """A supersampled frame: every pass but the post once per sample, each sub-frame's
        colour and visibility added to the sums (stage "accumulate"); then the primary
        pass again at the pixel centres (the G-buffer AOVs and the exposure's hit mask
        are those of one sample per pixel), the average, and the post."""
        s = self.settings
        post = self._post
        sampled = [p for p in self.passes if p is not post]
        step = sample_step(spp)
        for k, (sx, sy) in enumerate(sample_offsets(spp, s.sample_seed)):
            frame.sample_index = k
            frame.camera = make_camera_gpu(camera, s.width, s.height, sample=(sx, sy), sample_step=step)
            for p in sampled:
                p.execute(frame)
            with frame.timer.stage("accumulate"):
                self._accumulator.add(self.buffers.color, self.buffers.visibility, first=k == 0)
        frame.camera = make_camera_gpu(camera, s.width, s.height)
        self._primary.execute(frame)
        with frame.timer.stage("accumulate"):
            self._accumulator.average(spp, self.buffers.color, self.buffers.visibility)
        self.buffers.color_rows = self.buffers.color_cols = None
        post.execute(frame)

    @property
    def _primary(self) -> PrimaryVisibility:
        return next(p for p in self.passes if isinstance(p, PrimaryVisibility))

    @property
    def _guard(self) -> GuardedTrace | None:
        return next((p for p in self.passes if isinstance(p, GuardedTrace)), None)

    @property
    def tally(self) -> RayTally | None:
        """The last frame's ray tally by screen tile (None in raster mode)."""
        tracer = self.tracer
        return tracer.tally if tracer is not None else None

    @property
    def _post(self) -> PostProcess:
        return next(p for p in self.passes if isinstance(p, PostProcess))

    def _trace_stats(self, frame: FrameContext, rays: Any) -> dict[str, Any]:
        """The frame's tracing statistics."""
        layout = frame.region.layout
        full = frame.window is None
        ring = frame.region.ring
        spec = self.settings.ring_spec
        ring_stats = {}
        if spec is not None and not full:
            ring_stats["ring"] = {
                "scale": spec.scale,
                "step": spec.step,
                "traced": ring is not None,
                "pixels": ring.count if ring is not None else 0,
                "outer_fraction": ring.outer.covered_fraction if ring is not None else 0.0,
            }
        return {
            **ring_stats,
            "rays": rays.to_dict(),
            "window": {
                "gaze": list(frame.window.gaze) if not full else None,
                "fraction": 1.0 if full else frame.window.fraction,
                "shape": layout.shape,
                "centre_px": [layout.cx, layout.cy],
                "feather_px": layout.feather_px,
                "pixels": frame.region.count,
                "covered_fraction": layout.covered_fraction,
            },
        }
