"""The adaptive loop: one scene on one renderer under a frame-time budget, frame by frame.

``AdaptiveLoop`` owns the device state across frames (the renderer and its device
scene, the budget controller), like Warp's examples: ``advance(t)`` moves the scene to
``t`` seconds (re-evaluating only its time-varying prims, copying the moved points and
refitting the BVH), ``render(gaze)`` draws the frame there (the controller sizes the
focus window at the gaze and sets the deadline the budget guard traces under, then
learns from what the frame cost), and ``step(t, gaze)`` does both as one timed frame.
The replay command drives it from a gaze trace; a live viewer drives it with the
cursor as the gaze.

A frame's ``frame_ms`` covers everything a live viewer pays, from evaluating the scene
at the frame's time to the finished image: the stages ``scene_update`` (host
evaluation) and ``refit`` (upload and BVH refit) come first, then the renderer's
stages, then ``adapt`` (reading the ray tally for the controller).  Time flows through
the injected clock only, so a test with a fake clock and a cost model is deterministic.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from gaze.source import SACCADE, GazeSample

from ..adapt import BudgetController, ControllerSettings, FrameCost, WindowPlan
from ..adapt.saccade import SaccadePredictor
from ..errors import RenderSettingsError
from ..focus import FocusWindow
from ..renderer import Frame, Renderer, RenderSettings
from ..scene.model import Camera, Scene
from ..scene.usd.camera import select_camera
from ..scene.usd.loader import UsdSceneSource
from ..timing import Clock, perf_clock

#: The stages that trace; the controller's cost map learns their time.
TRACE_STAGES = ("trace_setup", "trace_shadow", "trace_secondary")
#: The stages after tracing (the controller reserves their time behind the deadline).
#: "relight" no longer runs (the raster layer is shaded everywhere); it stays in the
#: stats CSV's columns (always 0) so the file keeps its format.
AFTER_TRACE_STAGES = ("relight", "accumulate", "compose", "tonemap", "aa", "readback", "adapt")
#: Stages added later, their columns appended in this order: the shadow maps, the layer
#: behind alpha-blended surfaces, the ring's upsampling, the reflection probe, temporal reuse.
LATER_STAGES = ("shadow_maps", "alpha_layer", "upsample", "probes", "reuse")
#: Those of them that run after tracing (reserved behind the deadline as well).
LATER_AFTER_TRACE_STAGES = ("upsample", "reuse")
#: Every stage a frame can report (the stats CSV's stage columns): in frame order, then
#: the stages added later, appended so the existing columns keep their places.  "clear"
#: no longer runs (the primary passes write every pixel); its column stays, always 0.
FRAME_STAGES = (
    "scene_update",
    "refit",
    "clear",
    "raster",
    "resolve",
    "raycast",
    "surface",
    "focus",
    "lighting",
    *TRACE_STAGES,
    *AFTER_TRACE_STAGES,
    *LATER_STAGES,
)


@dataclass
class LoopSettings:
    """How the loop paces frames.

    ``fps``: the target frame rate; ``budget_ms`` overrides its budget (1000 / fps).
    ``adaptive``: in hybrid mode the controller sizes the window within
    [``min_window``, ``max_window``] (share of the screen) and the guard enforces the
    deadline; False keeps the render settings' fixed window.  ``start``: the first
    frame's time in seconds from the start of the stage's time range.  ``saccade``:
    while the gaze is labelled a saccade (vision is suppressed), the window (adaptive or
    fixed) is placed at the landing point ``adapt.saccade.SaccadePredictor`` predicts
    from the gaze samples (each frame's, and any the driver passes to ``saccade.add``
    between frames) instead of at the gaze.
    """

    fps: float = 15.0
    budget_ms: float | None = None
    adaptive: bool = True
    min_window: float = 0.01
    max_window: float = 1.0
    start: float = 0.0
    saccade: bool = False

    @property
    def budget(self) -> float:
        """The frame-time budget in ms."""
        return float(self.budget_ms) if self.budget_ms is not None else 1000.0 / self.fps

    def validate(self) -> None:
        """Raise ``RenderSettingsError`` for values that cannot be honoured."""
        if not (math.isfinite(self.fps) and self.fps > 0.0):
            raise RenderSettingsError(f"--fps must be a positive number, got {self.fps}")
        if self.budget_ms is not None and not (math.isfinite(self.budget_ms) and self.budget_ms > 0.0):
            raise RenderSettingsError(f"--budget-ms must be a positive number, got {self.budget_ms}")
        if not math.isfinite(self.start):
            raise RenderSettingsError(f"--start must be finite, got {self.start}")


@dataclass
class LoopFrame:
    """One finished frame of the loop and what it measured."""

    index: int
    t: float
    gaze: GazeSample
    frame: Frame
    plan: WindowPlan | None
    stages_ms: dict[str, float]
    frame_ms: float
    budget_ms: float
    window_fraction: float
    traced_fraction: float
    rays: dict[str, int] = field(default_factory=dict)

    @property
    def within_budget(self) -> bool:
        """The whole frame met the budget."""
        return self.frame_ms <= self.budget_ms

    def row(self) -> dict[str, Any]:
        """The frame's stats CSV row (``replay.stats_csv``'s columns)."""
        row: dict[str, Any] = {
            "frame": self.index,
            "t": self.t,
            "gaze_x": self.gaze.x,
            "gaze_y": self.gaze.y,
            "gaze_valid": self.gaze.valid,
            "saccade": self.gaze.label == SACCADE,
            "window_fraction": self.window_fraction,
            "traced_fraction": self.traced_fraction,
            "frame_ms": self.frame_ms,
            "budget_ms": self.budget_ms,
            "within_budget": self.within_budget,
        }
        row.update({f"{name}_ms": ms for name, ms in self.stages_ms.items()})
        for kind in ("shadow", "reflection", "refraction"):
            row[f"rays_{kind}"] = self.rays.get(kind, 0)
        return row


class AdaptiveLoop:
    """One scene under a frame-time budget, fed frame by frame (module docstring)."""

    def __init__(
        self,
        source: UsdSceneSource,
        render_settings: RenderSettings,
        settings: LoopSettings | None = None,
        camera_path: str | None = None,
        clock: Clock = perf_clock,
    ) -> None:
        """Evaluate ``source`` at the first frame's time, upload it and set up the
        controller; ``camera_path`` picks the camera (default: the first)."""
        self.settings = settings or LoopSettings()
        self.settings.validate()
        self.source = source
        self.camera_path = camera_path
        self.clock = clock
        self.scene: Scene = source.scene_at(self.time_code(self.settings.start))
        self.camera: Camera = self.camera_in(self.scene)
        self.renderer = Renderer(self.scene, render_settings, clock=clock)
        rs = self.renderer.settings
        self.controller: BudgetController | None = None
        if rs.mode == "hybrid" and self.settings.adaptive:
            controller_settings = ControllerSettings(
                budget_ms=self.settings.budget,
                min_window=self.settings.min_window,
                max_window=self.settings.max_window,
                ring=rs.ring_spec,
            )
            controller_settings.validate()
            self.controller = BudgetController(
                controller_settings, rs.width, rs.height, shape=rs.window_shape, feather_px=rs.feather_px
            )
        self.saccade = SaccadePredictor() if self.settings.saccade else None
        self._pending_ms: dict[str, float] = {}
        self._frame_start: float | None = None
        self.frames = 0

    def camera_in(self, scene: Scene) -> Camera:
        """The loop's camera (``camera_path``, or the first) in ``scene``."""
        return select_camera(scene.cameras, self.camera_path, source=str(self.source.path))

    def time_code(self, seconds: float) -> float:
        """The stage time code shown ``seconds`` after the start of its time range."""
        return self.source.info.time_code(seconds)

    def close(self) -> None:
        """Release the renderer's threads."""
        self.renderer.close()

    def __enter__(self) -> AdaptiveLoop:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def set_budget(self, budget_ms: float) -> None:
        """Aim at a frame-time budget of ``budget_ms`` from the next frame on (a live
        viewer's control); ``RenderSettingsError`` when it is not a positive number."""
        settings = dataclasses.replace(self.settings, budget_ms=float(budget_ms))
        settings.validate()
        self.settings = settings
        if self.controller is not None:
            self.controller.settings.budget_ms = settings.budget

    def advance(self, t: float) -> None:
        """Move the scene to ``t`` seconds (stages "scene_update" and "refit"); the time
        counts toward the next ``render``'s frame."""
        timer = self.renderer.new_timer()
        self._frame_start = timer.now()
        code = self.time_code(t)
        if code != self.scene.time:
            with timer.stage("scene_update"):
                scene = self.source.scene_at(code)
            refit_ms = self.renderer.update_scene(scene)
            self.scene = scene
            self.camera = self.camera_in(scene)
            timer.stages_ms["refit"] = refit_ms
        self._pending_ms = dict(timer.stages_ms)

    def render(self, gaze: GazeSample, t: float | None = None) -> LoopFrame:
        """Draw the frame at the current scene time looking at ``gaze``."""
        start = self._frame_start if self._frame_start is not None else self.renderer.new_timer().now()
        before = dict(self._pending_ms)
        self._pending_ms, self._frame_start = {}, None
        rs = self.renderer.settings
        budget = self.settings.budget
        plan: WindowPlan | None = None
        window: FocusWindow | None = None
        deadline: float | None = None
        centre = (gaze.x, gaze.y)
        if self.saccade is not None:
            self.saccade.add(gaze)
            landing = self.saccade.landing()
            if landing is not None:
                centre = landing.point
        if rs.mode == "hybrid":
            if self.controller is not None:
                plan = self.controller.plan(centre)
                window = FocusWindow(centre, plan.fraction, rs.window_shape, rs.feather_px)
                deadline = start + plan.trace_deadline_ms / 1000.0
            else:
                window = self.renderer.default_window(centre)
        frame = self.renderer.render(self.camera, window, trace_deadline=deadline, host_copies=False)
        stages = {**before, **frame.stats["stages_ms"]}
        timer = self.renderer.new_timer()
        with timer.stage("adapt"):
            tiles = self.renderer.tally.tiles() if self.controller is not None else None
        stages["adapt"] = timer.stages_ms["adapt"]
        frame_ms = (timer.now() - start) * 1000.0
        window_stats = frame.stats.get("window", {})
        screen_fraction = {"raster": 0.0, "full": 1.0}.get(rs.mode)
        window_fraction = window.fraction if window is not None else screen_fraction
        traced = window_stats.get("covered_fraction", screen_fraction if screen_fraction is not None else 0.0)
        if self.controller is not None and tiles is not None:
            trace_ms = sum(stages.get(k, 0.0) for k in TRACE_STAGES)
            after_ms = sum(stages.get(k, 0.0) for k in (*AFTER_TRACE_STAGES, *LATER_AFTER_TRACE_STAGES))
            self.controller.observe(
                FrameCost(
                    frame_ms=frame_ms,
                    # everything else, the host time between the stages included, is fixed cost
                    before_trace_ms=max(frame_ms - trace_ms - after_ms, 0.0),
                    trace_ms=trace_ms,
                    after_trace_ms=after_ms,
                    tile_pixels=tiles.pixels,
                    tile_rays=tiles.rays,
                )
            )
        index = self.frames
        self.frames += 1
        return LoopFrame(
            index=index,
            t=float(t) if t is not None else float(gaze.t),
            gaze=gaze,
            frame=frame,
            plan=plan,
            stages_ms=stages,
            frame_ms=frame_ms,
            budget_ms=budget,
            window_fraction=float(window_fraction),
            traced_fraction=float(traced),
            rays=frame.stats.get("rays", {}),
        )

    def step(self, t: float, gaze: GazeSample) -> LoopFrame:
        """``advance(t)`` then ``render(gaze)``: one whole frame."""
        self.advance(t)
        return self.render(gaze, t)
