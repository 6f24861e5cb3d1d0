"""The viewer's render loop: its own thread, the adaptive loop driven continuously.

Each iteration applies the controls queued since the last frame (``submit``: every
public control method is safe from any thread and takes effect between frames), moves
the scene to the timeline's time, samples the gaze, renders under the budget, encodes
the JPEG and publishes it to the ``FrameHub`` (which never waits for a page), then
sleeps to the next frame slot of the target rate.  ``health`` counts frames and the
longest interval between two frame starts, in the loop's own numbers.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import cv2

from gaze.errors import GazeError

from ..errors import WarpHybridError
from ..renderer import RenderSettings
from ..replay.loop import AdaptiveLoop, LoopFrame, LoopSettings
from ..replay.run import overlay_geometry
from ..scene.usd.loader import UsdSceneSource
from .calibration import CalibrationSession
from .gaze_feed import GazeFeed, PointerTag, open_feed, webcam_spec
from .hub import FrameHub
from .navigation import Navigator
from .protocol import pack_frame, server_message
from .recorder import Recorder
from .timeline import Timeline, stage_duration

log = logging.getLogger("warp_hybrid.viewer")

#: After a frame fails, the loop waits this long before the next try.
ERROR_PAUSE_S = 1.0
#: Frame starts kept for the measured frame rate.
RATE_WINDOW = 30


@dataclass
class ViewSettings:
    """What the viewer renders: the frame and budget settings, the camera, the gaze
    spec (``cursor``, ``webcam:...``, ``trace:...``), the JPEG quality, where
    recordings and the webcam calibration go."""

    render: RenderSettings
    loop: LoopSettings
    camera_path: str | None = None
    gaze: str = "cursor"
    jpeg_quality: int = 80
    record_dir: Path = Path("recordings")
    calibration_file: Path = Path("calibration.json")


class LoopHealth:
    """Frame starts as the loop saw them: count, measured rate, longest interval."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._starts: deque[float] = deque(maxlen=RATE_WINDOW)
        self.frames = 0
        self.max_interval_s = 0.0

    def record(self, start: float) -> None:
        """A frame started at ``start`` (loop thread)."""
        with self._lock:
            if self._starts:
                self.max_interval_s = max(self.max_interval_s, start - self._starts[-1])
            self._starts.append(start)
            self.frames += 1

    def reset_interval(self) -> None:
        """Forget the longest interval so far (e.g. after a warm-up)."""
        with self._lock:
            self.max_interval_s = 0.0

    @property
    def fps(self) -> float:
        """Frames per second over the last ``RATE_WINDOW`` frame starts (0 before two)."""
        with self._lock:
            if len(self._starts) < 2 or self._starts[-1] <= self._starts[0]:
                return 0.0
            return (len(self._starts) - 1) / (self._starts[-1] - self._starts[0])


def encode_jpeg(image: Any, quality: int) -> bytes:
    """An (H, W, 3) uint8 RGB image as JPEG bytes (OpenCV)."""
    ok, data = cv2.imencode(".jpg", cv2.cvtColor(image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise RuntimeError("OpenCV could not encode the frame as JPEG")
    return data.tobytes()


def window_header(frame: LoopFrame) -> dict[str, Any] | None:
    """The frame's focus window for the page's overlay (replay's overlay geometry), or None."""
    geometry = overlay_geometry(frame)
    if geometry is None:
        return None
    centre, shape, half_w, half_h, _, traced = geometry
    return {"centre": list(centre), "shape": shape, "half_w": half_w, "half_h": half_h, "traced": traced}


class RenderThread:
    """Drives one ``AdaptiveLoop`` in a thread of its own (module notes)."""

    def __init__(
        self,
        source: UsdSceneSource,
        settings: ViewSettings,
        hub: FrameHub,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """Build the loop (a bad camera or setting raises here, before any thread) and open the gaze."""
        self.source = source
        self.settings = settings
        self.hub = hub
        self.clock = clock
        self.loop = AdaptiveLoop(source, replace(settings.render), replace(settings.loop), settings.camera_path)
        self.cameras = [c.name for c in self.loop.scene.cameras]
        self.feed: GazeFeed = open_feed(settings.gaze)
        self.recorder = Recorder(settings.record_dir, str(source.path))
        self.timeline = Timeline(stage_duration(source.info), clock())
        self.health = LoopHealth()
        self.navigator: Navigator | None = None
        self.calibration: CalibrationSession | None = None
        self.warm = threading.Event()
        self.state: dict[str, Any] = {}
        self._commands: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._started = clock()
        self._update_state()

    # ---- lifecycle -------------------------------------------------------------------------

    def start(self) -> None:
        """Start rendering in the background."""
        self._thread = threading.Thread(target=self._run, name="viewer render loop", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 30.0) -> None:
        """Stop after the frame in progress; release the loop and the gaze source."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None
        self.loop.close()
        self.feed.close()

    def submit(self, command: Callable[[], None]) -> None:
        """Run ``command`` on the render thread before its next frame (any thread)."""
        self._commands.put(command)

    # ---- controls (any thread; applied between frames) --------------------------------------

    def set_budget(self, budget_ms: float) -> None:
        """Aim at a frame-time budget of ``budget_ms``."""
        self.submit(lambda: self.loop.set_budget(budget_ms))

    def set_render(self, **changes: Any) -> None:
        """Rebuild the loop with other render settings (``mode``, ``window_shape``)."""
        self.submit(lambda: self._rebuild(**changes))

    def select_camera(self, name: str) -> None:
        """Look through the scene camera ``name`` (navigation dropped)."""

        def apply() -> None:
            self.loop.camera_path = name
            self.navigator = None
            self.loop.camera = self.loop.camera_in(self.loop.scene)

        self.submit(apply)

    def navigate(self, kind: str, dx: float, dy: float) -> None:
        """Orbit, pan or zoom the camera by a drag of (dx, dy) shares of the frame."""

        def apply() -> None:
            if self.navigator is None:
                lo, hi = self.loop.scene.bounds
                self.navigator = Navigator(self.loop.camera, 0.5 * (lo + hi), self.loop.scene.up_axis)
            rs = self.loop.renderer.settings
            if kind == "orbit":
                self.navigator.orbit(dx, dy)
            elif kind == "pan":
                self.navigator.pan(dx, dy, rs.width / rs.height)
            else:
                self.navigator.zoom(dy)

        self.submit(apply)

    def reset_view(self) -> None:
        """Back to the scene camera's own pose."""

        def apply() -> None:
            self.navigator = None
            self.loop.camera = self.loop.camera_in(self.loop.scene)

        self.submit(apply)

    def play(self, playing: bool) -> None:
        """Play or pause the animation."""
        self.submit(lambda: self.timeline.play(playing, self.clock()))

    def seek(self, t: float) -> None:
        """Show scene time ``t`` seconds."""
        self.submit(lambda: self.timeline.seek(t, self.clock()))

    def record(self, start: bool, client: int) -> None:
        """Start or stop recording; the result goes to ``client`` as an event."""
        self.submit(lambda: self._record(start, client))

    def calibrate(self, start: bool, client: int) -> None:
        """Start (or cancel) the webcam calibration; its steps go to every page."""
        self.submit(lambda: self._calibrate(start, client))

    # ---- the loop --------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            self.loop.renderer.warm_up(self.loop.camera)
        except Exception as exc:  # reported to the pages; the loop keeps trying below
            log.exception("warm-up failed")
            self.hub.send_event(server_message("error", message=f"warm-up failed: {exc}"))
        self.warm.set()
        next_start = self.clock()
        while not self._stop.is_set():
            start = self.clock()
            try:
                self._frame(start)
            except Exception as exc:  # a failing frame never ends the viewer
                log.exception("frame failed")
                self.hub.send_event(server_message("error", message=f"frame failed: {exc}"))
                self._stop.wait(ERROR_PAUSE_S)
            next_start = max(next_start + self.loop.settings.budget / 1000.0, start)
            self._stop.wait(max(0.0, next_start - self.clock()))

    def _apply_commands(self) -> None:
        while True:
            try:
                command = self._commands.get_nowait()
            except queue.Empty:
                return
            try:
                command()
            except (WarpHybridError, GazeError, ValueError, OSError) as exc:
                log.warning("control refused: %s", exc)
                self.hub.send_event(server_message("error", message=str(exc)))

    def _frame(self, start: float) -> None:
        self._apply_commands()
        self.health.record(start)
        t = self.timeline.time(start)
        gaze, tag = self.feed.sample(start - self._started)
        self.loop.advance(t)
        if self.navigator is not None:
            self.loop.camera = self.navigator.camera()
        frame = self.loop.render(gaze, t)
        encode_start = self.clock()
        jpeg = encode_jpeg(frame.frame.image, self.settings.jpeg_quality)
        encode_ms = 1000.0 * (self.clock() - encode_start)
        self._update_state()
        header = self._header(frame, tag, encode_ms)
        self.hub.publish(pack_frame(header, jpeg))
        self.recorder.add(start - self._started, gaze, self.loop.camera)
        if self.calibration is not None:
            self._calibration_step(start)

    def _header(self, frame: LoopFrame, tag: PointerTag | None, encode_ms: float) -> dict[str, Any]:
        rs = self.loop.renderer.settings
        plan = frame.plan
        return {
            "index": self.health.frames,
            "t": frame.t,
            "width": rs.width,
            "height": rs.height,
            "gaze": {"x": frame.gaze.x, "y": frame.gaze.y, "valid": frame.gaze.valid},
            "window": window_header(frame),
            "stats": {
                "frame_ms": frame.frame_ms,
                "budget_ms": frame.budget_ms,
                "within_budget": frame.within_budget,
                "window_fraction": frame.window_fraction,
                "traced_fraction": frame.traced_fraction,
                "infeasible": bool(plan.infeasible) if plan is not None else False,
                "stages_ms": {k: v for k, v in frame.stages_ms.items() if v > 0.0},
                "loop_fps": self.health.fps,
                "encode_ms": encode_ms,
            },
            "pointer": tag.header(self.clock()) if tag is not None else None,
            "state": self.state,
        }

    def _update_state(self) -> None:
        rs = self.loop.renderer.settings
        self.state = {
            "mode": rs.mode,
            "shape": rs.window_shape,
            "budget_ms": self.loop.settings.budget,
            "fps": 1000.0 / self.loop.settings.budget,
            "camera": self.loop.camera_in(self.loop.scene).name,
            "navigating": self.navigator is not None,
            "playing": self.timeline.playing,
            "t": self.timeline.time(self.clock()),
            "duration": self.timeline.duration,
            "recording": self.recorder.recording,
            "calibrating": self.calibration is not None,
            "gaze": self.feed.kind,
        }

    def _rebuild(self, **changes: Any) -> None:
        """A new loop with other render settings (same scene, camera, budget)."""
        render = replace(self.loop.renderer.settings, **changes)
        render.validate()
        old = self.loop
        self.loop = AdaptiveLoop(self.source, render, replace(old.settings), old.camera_path)
        old.close()
        self.loop.renderer.warm_up(self.loop.camera)

    def _record(self, start: bool, client: int) -> None:
        if start:
            self.recorder.start(self.clock() - self._started, self.timeline.time(self.clock()))
            self.hub.send_event(server_message("event", name="recording", recording=True), client)
            return
        if not self.recorder.recording:
            raise ValueError("not recording")
        written = self.recorder.stop(1000.0 / self.loop.settings.budget, self.loop.camera_path)
        log.info("recorded %s", written["trace"])
        self.hub.send_event(server_message("event", name="recorded", recording=False, **written), client)

    def _calibrate(self, start: bool, client: int) -> None:
        if not start:
            self.calibration = None
            self.hub.send_event(server_message("event", name="calibration", state="cancelled"))
            return
        self.calibration = CalibrationSession(self.clock())

    def _calibration_step(self, now: float) -> None:
        session = self.calibration
        assert session is not None
        step = session.collect(now, self.feed.raw(now - self._started))
        if step is not None:
            event = server_message("event", name="calibration", state="target", index=step.index, x=step.x, y=step.y)
            self.hub.send_event(event)
        if not session.done(now):
            return
        self.calibration = None
        path = self.settings.calibration_file
        try:
            fitted = session.fit_and_save(path)
        except GazeError as exc:
            self.hub.send_event(server_message("event", name="calibration", state="failed", message=str(exc)))
            return
        spec = f"{webcam_spec(self.settings.gaze)}?calibration={path}"
        self.feed.close()
        self.feed = open_feed(spec)
        self.settings.gaze = spec
        event = server_message(
            "event", name="calibration", state="done", path=str(path), residual_rms=fitted.residual_rms
        )
        self.hub.send_event(event)
