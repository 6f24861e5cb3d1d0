"""What the budget controller is told, what it measures and what it answers.

``ControllerSettings`` holds the budget and every tunable (each documented below,
with the Unreal Engine dynamic-resolution console variable it mirrors, where one
does); ``FrameCost`` is what one finished frame measured; ``WindowPlan`` is the
controller's answer before a frame.  All times are milliseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import RenderSettingsError
from ..focus.ring import RingSpec


@dataclass
class ControllerSettings:
    """The frame-time budget and the controller's tunables.

    Budget and bounds:

    - ``budget_ms``: the frame-time budget, ``1000 / fps``.
    - ``min_window``, ``max_window``: bounds of the window's area, as a share of the
      screen (``0 <= min <= max <= 1``, ``max > 0``).
    - ``target_share``: the share of the budget the controller aims at, leaving head
      room for noise (Unreal: ``r.DynamicRes.TargetedGPUHeadRoomPercentage`` = 10 %).

    History of the stages the window does not drive (before and after tracing):

    - ``history_weight``: weight of frame N-1 against frame N in their weighted mean
      (Unreal: ``r.DynamicRes.FrameWeightExponent`` = 0.9).
    - ``history_size``: frames kept in that history (Unreal: ``r.DynamicRes.HistorySize`` = 16).

    The trace cost model:

    - ``cost_forgetting``: forgetting factor of the least-squares fit of the per-unit
      trace costs, along the direction each new frame measures again (directional
      forgetting: memory about ``1 / (1 - f)`` frames of the same mix of rays; what other
      mixes cost is kept until they are measured again).
    - ``cost_prior``: strength of the fit's prior "a traced pixel and every ray cost the
      same", relative to one frame's information: it only decides what the frames cannot
      tell apart (a cost type that never varied).
    - ``tile_forgetting``: how much a tile's rays-per-pixel estimate keeps of its past
      when the tile is traced again in full (a partly traced tile forgets less).
    - ``prior_pixels``: weight, in traced pixels, of the prior a tile's rays per pixel
      start from (its traced neighbours, else the mean of all traced tiles).
    - ``tile_px``: the side of a screen tile in pixels.

    Control:

    - ``panic_frames``: after this many consecutive frames over the budget, the history
      restarts and the next window is cut at once to the smaller of the model's window and
      what the last frame's measured cost per traced pixel allows (Unreal:
      ``r.DynamicRes.MaxConsecutiveOverbudgetGPUFrameCount`` = 2).
    - ``increase_blend``: an increase moves this share of the way from the current
      window to the predicted one per frame (Unreal:
      ``r.DynamicRes.IncreaseAmortizationBlendFactor`` = 0.9); decreases are not amortised.
    - ``max_growth``: and grows the window by at most this share of its area per frame.
    - ``change_threshold``: a predicted change of less than this share of the current
      window is ignored, as long as the current window is still predicted to meet the
      budget, and an amortised increase whose remainder is less completes (Unreal:
      ``r.DynamicRes.ChangePercentageThreshold`` = 2 %, for increases only).
    - ``surprise``: a frame whose measured trace (or non-trace) time exceeds the
      model's prediction for it by more than this share re-levels the model at once
      instead of waiting for the forgetting factor; ``panic_frames`` frames in a row
      whose trace time falls short of it by as much re-level it down.
    - ``skip_frames``: the first frames observed are not learnt from (e.g. one that
      compiles kernels).

    The traced area:

    - ``ring``: the mid-resolution ring every window gets (``focus.ring.RingSpec``), or
      None: with one, a window's predicted cost includes its ring's lattice pixels, so
      the window and its ring are sized together.
    """

    budget_ms: float
    min_window: float = 0.01
    max_window: float = 1.0
    target_share: float = 0.9
    history_weight: float = 0.9
    history_size: int = 16
    cost_forgetting: float = 0.95
    cost_prior: float = 0.01
    tile_forgetting: float = 0.5
    prior_pixels: float = 256.0
    tile_px: int = 32
    panic_frames: int = 2
    increase_blend: float = 0.5
    max_growth: float = 1.0
    change_threshold: float = 0.02
    surprise: float = 0.25
    skip_frames: int = 0
    ring: RingSpec | None = None

    def validate(self) -> None:
        """Raise ``RenderSettingsError`` naming the first value that cannot be honoured."""
        _number(self, "budget_ms", low=0.0, low_open=True)
        _number(self, "min_window", low=0.0, high=1.0)
        _number(self, "max_window", low=0.0, high=1.0, low_open=True)
        if self.min_window > self.max_window:
            raise RenderSettingsError(
                f"controller min_window ({self.min_window}) must not exceed max_window ({self.max_window})"
            )
        _number(self, "target_share", low=0.0, high=1.0, low_open=True)
        _number(self, "history_weight", low=0.0, high=1.0, low_open=True)
        _integer(self, "history_size", low=1)
        _number(self, "cost_forgetting", low=0.0, high=1.0, low_open=True)
        _number(self, "cost_prior", low=0.0)
        _number(self, "tile_forgetting", low=0.0, high=1.0)
        _number(self, "prior_pixels", low=0.0, low_open=True)
        _integer(self, "tile_px", low=1)
        _integer(self, "panic_frames", low=1)
        _number(self, "increase_blend", low=0.0, high=1.0, low_open=True)
        _number(self, "max_growth", low=0.0, low_open=True)
        _number(self, "change_threshold", low=0.0, high=1.0, high_open=True)
        _number(self, "surprise", low=0.0, low_open=True)
        _integer(self, "skip_frames", low=0)
        if self.ring is not None:
            if not isinstance(self.ring, RingSpec):
                raise RenderSettingsError(f"controller ring must be a RingSpec or None, got {self.ring!r}")
            self.ring.validate()


def _number(
    settings: ControllerSettings,
    name: str,
    low: float,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
) -> None:
    """Check that a field is a finite real number within [low, high] (open ends as asked)."""
    value = getattr(settings, name)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise RenderSettingsError(f"controller {name} must be a number, got {value!r}")
    value = float(value)
    below = value <= low if low_open else value < low
    above = high is not None and (value >= high if high_open else value > high)
    if not math.isfinite(value) or below or above:
        lo_br, hi_br = ("(" if low_open else "["), (")" if high_open else "]")
        span = f"{lo_br}{low}, {high}{hi_br}" if high is not None else f"{lo_br}{low}, inf)"
        raise RenderSettingsError(f"controller {name} must be finite and in {span}, got {value}")


def _integer(settings: ControllerSettings, name: str, low: int) -> None:
    """Check that a field is a whole number >= low."""
    value = getattr(settings, name)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise RenderSettingsError(f"controller {name} must be a whole number >= {low}, got {value!r}")


@dataclass
class FrameCost:
    """What one finished frame measured (a real clock, or an injected cost model).

    ``frame_ms``: the whole frame, from evaluating the scene at the frame's time to the
    finished image.  ``before_trace_ms``: every stage before tracing (scene update,
    refit, raster, surface, focus, lighting).  ``trace_ms``: the tracing stages.
    ``after_trace_ms``: every stage after tracing (compose, tonemap, aa, readback).
    ``tile_pixels``: (tiles_y, tiles_x) int, pixels traced per screen tile this frame.
    ``tile_rays``: (tiles_y, tiles_x, 3) int, shadow, reflection and refraction rays
    traced per tile.
    """

    frame_ms: float
    before_trace_ms: float
    trace_ms: float
    after_trace_ms: float
    tile_pixels: np.ndarray
    tile_rays: np.ndarray

    @property
    def traced_pixels(self) -> int:
        """Pixels traced this frame."""
        return int(np.asarray(self.tile_pixels).sum())


@dataclass
class WindowPlan:
    """The controller's answer before a frame.

    ``fraction``: this frame's window area (share of the screen), in
    [min_window, max_window], never NaN or negative.  ``predicted_frame_ms``,
    ``predicted_trace_ms``: what the model expects this window to cost (NaN while
    nothing has been measured, ``reason == "warmup"``).  ``trace_deadline_ms``: ms after
    the frame's start by which tracing must stop so the frame still meets the budget
    (the budget less the predicted after-trace stages, never below 0; the budget
    itself during warm-up); the renderer's guard stops tracing there.
    ``infeasible``: even the minimum window is predicted to miss the budget (the
    stages before and after tracing alone are too slow); then ``fraction == min_window``.
    ``reason``: ``"warmup"`` (nothing measured yet: the initial window), ``"predict"``
    (the largest window predicted to fit the target), ``"grow"`` (an amortised step
    towards a larger predicted window), ``"hold"`` (the predicted change is under the
    change threshold and the current window still fits the budget), ``"panic"``
    (frames over the budget in a row: cut to what the last frame's cost allows) or
    ``"infeasible"``.
    """

    fraction: float
    predicted_frame_ms: float
    predicted_trace_ms: float
    trace_deadline_ms: float
    infeasible: bool
    reason: str
