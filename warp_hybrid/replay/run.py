"""Replay a gaze source over a scene at a fixed time step: video, stats CSV, summary.

Frame ``i`` shows scene time ``start + i / fps`` seconds (mapped to time codes through
the stage's timeCodesPerSecond) and samples the gaze source at the same time, so a
replay is reproducible whatever the machine; the budget is checked against each
frame's measured time.  Outputs are written under temporary names and renamed when
the replay ends, also when it is interrupted (Ctrl-C, SIGTERM): the video then holds
the frames done and the CSV one whole row per frame done.

A gaze source that fails mid-replay (a webcam unplugged, a trace shorter than the
replay) never stops it: ``SteadyGaze`` holds the last valid point with
``gaze_valid = 0``.
"""

from __future__ import annotations

import math
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gaze.errors import GazeError
from gaze.source import GazeSample, GazeSource, centre_sample

from ..output import write_json, write_png
from .frame_error import FrameErrors, error_summary, write_errors
from .loop import FRAME_STAGES, AdaptiveLoop, LoopFrame
from .overlay import draw_overlay
from .progress import Progress
from .stats_csv import StatsWriter
from .summary import summarize
from .video import VideoWriter


class ReplayInterrupted(KeyboardInterrupt):
    """SIGTERM during a replay (Ctrl-C raises ``KeyboardInterrupt``)."""


class SteadyGaze:
    """A gaze source that never fails: past its end, or when it raises, it holds the
    last valid point with ``valid = False`` and confidence 0."""

    def __init__(self, source: GazeSource) -> None:
        """Wrap ``source`` (already started)."""
        self.source = source
        self.duration: float | None = getattr(source, "duration", None)
        self.last_valid: GazeSample | None = None
        self.failure: str | None = None

    def sample(self, t: float) -> GazeSample:
        """The gaze at ``t`` seconds, or the held point."""
        sample: GazeSample | None = None
        if self.failure is None and (self.duration is None or t <= self.duration):
            try:
                sample = self.source.sample(t)
            except (GazeError, OSError, RuntimeError, ValueError) as exc:
                self.failure = str(exc)
        if sample is not None and sample.valid:
            self.last_valid = sample
            return sample
        held = self.last_valid or sample or centre_sample(t)
        return GazeSample(held.x, held.y, t, confidence=0.0, valid=False)


def recorded_times(source: GazeSource, after: float, before: float) -> list[float]:
    """The times of a recorded trace's own samples in ``(after, before)`` (what the
    tracker reported between two frames, for the saccade predictor); none for a source
    that is not a recording."""
    times = getattr(getattr(source, "data", None), "t", None)
    if times is None:
        return []
    times = np.asarray(times, dtype=float)
    return times[np.searchsorted(times, after, side="right") : np.searchsorted(times, before, side="left")].tolist()


@dataclass
class ReplayOutputs:
    """Where a replay writes: the video (None: none), the stats CSV (None: none), the
    summary JSON (None: none), a PNG per frame (None: none), whether the video shows
    the window outline and the gaze point, and the per-frame error CSV against
    references of ``error_spp`` samples per pixel (None: none; ``frame_error``)."""

    video: Path | None = None
    stats: Path | None = None
    summary_json: Path | None = None
    frames_dir: Path | None = None
    overlay: bool = False
    errors: Path | None = None
    error_spp: int = 16


@dataclass
class ReplayResult:
    """What a replay did: frames rendered, whether it was interrupted, the summary."""

    frames: int
    interrupted: bool
    summary: dict[str, Any] = field(default_factory=dict)
    gaze_failure: str | None = None


class _Interrupts:
    """Ctrl-C (SIGINT) and SIGTERM during a replay (main thread only): raised at once
    (``KeyboardInterrupt``, ``ReplayInterrupted``) while a frame renders, but held back
    while the frame's outputs are written (``writing``) and raised when they are, so
    the video, the CSV and the frames folder always hold the same frames."""

    def __init__(self) -> None:
        """Not installed until entered."""
        self.pending: KeyboardInterrupt | None = None
        self.held = False

    def _handler(self, signum: int, frame: object) -> None:
        exc = ReplayInterrupted() if signum == signal.SIGTERM else KeyboardInterrupt()
        if self.held:
            self.pending = exc
            return
        raise exc

    @contextmanager
    def installed(self) -> Iterator[None]:
        """The handlers for SIGINT and SIGTERM while the replay runs (none off the main thread)."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        previous = {sig: signal.signal(sig, self._handler) for sig in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)

    @contextmanager
    def writing(self) -> Iterator[None]:
        """Hold an interruption back until the block ends, then raise it."""
        self.held = True
        try:
            yield
        finally:
            self.held = False
        if self.pending is not None:
            exc, self.pending = self.pending, None
            raise exc


def overlay_geometry(frame: LoopFrame) -> tuple[Any, ...] | None:
    """What ``draw_overlay`` draws for a frame: the planned window's centre (px), shape,
    half width and half height, the gaze point (px) and how far tracing got when it
    stopped short (a circle's radius, else None); None for a frame without a window."""
    window = frame.frame.stats.get("window")
    if window is None or window.get("gaze") is None:
        return None
    rs_w, rs_h = frame.frame.stats["resolution"]
    guard = frame.frame.stats.get("guard")
    layout_shape = window["shape"]
    cx, cy = window["centre_px"]
    planned = frame.window_fraction
    scale = math.sqrt(planned * rs_w * rs_h / math.pi) if layout_shape == "circle" else None
    traced = None
    if guard is not None and guard["rings_traced"] < guard["rings"] and scale is not None:
        traced = scale * math.sqrt(guard["rings_traced"] / guard["rings"])
    half_w = scale if scale is not None else math.sqrt(planned) * rs_w / 2.0
    half_h = scale if scale is not None else math.sqrt(planned) * rs_h / 2.0
    gaze = (frame.gaze.x * rs_w, frame.gaze.y * rs_h)
    return (cx, cy), layout_shape, half_w, half_h, gaze, traced


def _overlaid(frame: LoopFrame) -> Any:
    """The frame's image with the planned window, the traced one and the gaze drawn."""
    geometry = overlay_geometry(frame)
    return frame.frame.image if geometry is None else draw_overlay(frame.frame.image, *geometry)


def _measure_errors(errors: FrameErrors, path: Path, progress: bool | None) -> dict[str, Any]:
    """Measure the kept frames against their references, write ``path``, return the medians."""
    with Progress(len(errors.kept), enabled=progress, unit="reference", budgeted=False) as bar:
        rows = errors.measure(on_row=bar.update)
    write_errors(path, rows)
    return {"errors": {"reference_spp": errors.spp, "frames": len(rows), **error_summary(rows)}}


def replay(
    loop: AdaptiveLoop,
    gaze: GazeSource,
    frames: int,
    outputs: ReplayOutputs,
    warm_up: int = 3,
    progress: bool | None = None,
    on_frame: Callable[[LoopFrame], None] | None = None,
) -> ReplayResult:
    """Render ``frames`` frames of ``loop`` at its fps looking where ``gaze`` says, into
    ``outputs``; ``warm_up`` untimed frames first (kernels compiled, the controller
    primed) at the first frame's time; ``on_frame`` sees every finished frame.  Returns
    the summary; an interruption ends the replay early with whole outputs
    (``interrupted`` set).  With ``outputs.errors``, every frame's error against its
    reference is measured after the timed frames (not after an interruption) and its
    medians join the summary.  With the loop's saccade predictor (``--saccade``), the
    trace's recorded samples between two frames reach it before each frame."""
    settings = loop.settings
    steady = SteadyGaze(gaze)
    rs = loop.renderer.settings
    first = steady.sample(settings.start)
    loop.renderer.warm_up(loop.camera)
    for _ in range(warm_up):
        loop.step(settings.start, first)
    loop.frames = 0
    slim: list[dict[str, float]] = []
    interrupted = False
    video = VideoWriter(outputs.video, rs.width, rs.height, settings.fps) if outputs.video else None
    stats = StatsWriter(outputs.stats, FRAME_STAGES) if outputs.stats else None
    errors = FrameErrors(loop, outputs.error_spp) if outputs.errors else None
    if loop.saccade is not None:
        loop.saccade.screen = getattr(gaze, "screen", loop.saccade.screen)  # the geometry of its I-VT labels
    interrupts = _Interrupts()
    try:
        with interrupts.installed(), Progress(frames, enabled=progress) as bar:
            for i in range(frames):
                t = settings.start + i / settings.fps
                if loop.saccade is not None:
                    for between in recorded_times(gaze, t - 1.0 / settings.fps, t):
                        loop.saccade.add(steady.sample(between))
                frame = loop.step(t, steady.sample(t))
                with interrupts.writing():
                    if video is not None:
                        video.write(_overlaid(frame) if outputs.overlay else frame.frame.image)
                    if stats is not None:
                        stats.write_row(frame.row())
                    if outputs.frames_dir is not None:
                        write_png(outputs.frames_dir / f"frame_{i:05d}.png", frame.frame.image)
                    slim.append({"frame_ms": frame.frame_ms, "traced_fraction": frame.traced_fraction})
                    if errors is not None:
                        errors.keep(frame)
                bar.update(frame.within_budget)
                if on_frame is not None:
                    on_frame(frame)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if video is not None:
            video.close()
        if stats is not None:
            stats.close()
    summary = summarize(
        slim,
        settings.budget,
        encode_ms=video.encode_ms if video is not None else None,
        encoded_frames=video.frames if video is not None else None,
    )
    if errors is not None:
        with errors:
            if not interrupted:
                summary.update(_measure_errors(errors, outputs.errors, progress))
    if outputs.summary_json is not None:
        write_json(outputs.summary_json, {**summary, "interrupted": interrupted, "gaze_failure": steady.failure})
    return ReplayResult(len(slim), interrupted, summary, steady.failure)
