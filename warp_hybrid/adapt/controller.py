"""The frame-time budget controller: size the traced focus window so the frame rate holds.

The paper's idea (Martinez et al., section 4): the target frame rate is a budget; the
window around the gaze grows where the scene under it is cheap to trace and shrinks
where it is expensive.  The paper reacted to the last frame's total time alone; this
controller predicts, then guards.

Predict.  ``TraceCostModel`` (model.py) learns, from every frame's measurements, the
cost of a traced pixel and of each ray type, and per screen tile the rays a traced
pixel sends; with them it predicts the trace time of any window at any gaze.  The
stages before and after tracing are not driven by the window; each is predicted by
Unreal's weighted history of recent frames.  ``plan`` sizes the window as the largest
fraction in [min_window, max_window] whose predicted frame (before + trace + after)
fits ``target_share * budget``.  The predicted cost grows with the fraction (a larger
window at the same gaze covers more pixels; only the shift at the screen edges breaks
strict nesting), so a bracketing root search finds it (``largest_fitting``: proportional
steps, then regula falsi with bisection as the safeguard, 3 to 6 window layouts a plan).
The window therefore shrinks in the frame the gaze lands on glass the model has seen,
not one frame later.  ``trace_deadline_ms`` (the budget less the predicted after-trace stages)
lets the renderer guard the budget when the prediction is wrong.

Control, after Unreal Engine's dynamic-resolution heuristic (DynamicResolution.cpp):

- Follows: the target is 90 % of the budget (``TargetedGPUHeadRoomPercentage``); the
  weighted frame history (``FrameWeightExponent`` 0.9, ``HistorySize`` 16), here for the
  non-trace stages; the panic after ``MaxConsecutiveOverbudgetGPUFrameCount`` = 2
  frames over the budget, which skips the threshold and the amortisation, resets the
  history (here also re-levels the trace model to the last frame) and sizes the next
  window from the over-budget frame alone (here: the smaller of the model's window and
  the one the last frame's measured ms per traced pixel allows); increases amortised by
  a blend towards the new size (``IncreaseAmortizationBlendFactor``: 0.5 here where
  Unreal uses 0.9, plus a cap on the growth per frame, ``max_growth``); the change
  threshold (``ChangePercentageThreshold`` 2 %) that ignores small increases.
- Departs: Unreal's cost model is the square-root rule, GPU time proportional to the
  resolution fraction squared (i.e. to the pixel count), so it scales the fraction by
  ``sqrt(target / time)``.  The window's fraction is already an area, so the same
  assumption would scale it by ``target / time`` (the first step of ``largest_fitting``
  does exactly that) -- but only the trace stages grow with the window, and not
  uniformly: the non-trace stages are a fixed cost here (the ``B`` term Unreal's
  comments say it ignores) and the trace cost depends on where the window lies, not on
  its area alone.  Unreal thresholds increases only and takes any decrease; here a
  decrease under the threshold is held too, as long as the current window is still
  predicted to meet the budget (a dead band between the target and the budget, against
  oscillation), while a predicted overrun of the budget, or a larger decrease, shrinks
  at once.  Unreal delays every non-panic change by ``MinResolutionChangePeriod`` (8
  frames) for TAA's sake; a window change disturbs no temporal history here, so there is
  no such period.  Unreal's lerp towards the target approaches it forever and stops
  within the threshold below it; here an increase whose remainder is under the
  threshold completes (so the window reaches ``max_window``).  Unreal's outlier
  rejection (off by default) becomes the re-level and roll-back below.

Surprises.  A frame whose trace time (or before / after time) exceeds what the model
predicted for the pixels and rays it actually traced by more than ``surprise``
re-levels the model at once: every past trace measurement is scaled by measured over
predicted (the model keeps where cost lies and jumps to the new level); the frame's
totals do not enter the fit (its rays per tile do), since a frame that stalled while
the guard cut its window short would read there as a large fixed cost, a wrong shape
that scaling alone cannot undo.  The non-trace history restarts at the frame.  If the
next frame fits the model from before the surprise better, as a ratio, than the
re-levelled one (and surprises no other stage), the surprise was a one-frame spike: the
model and the window go back to where they were.  With the panic as the backstop, a
frame is back within the budget by the second frame after a sudden, lasting cost spike
(in the tests, by the first).  The other way, ``panic_frames`` frames in a row whose
trace time is below the prediction by more than ``surprise`` re-level the model down to
the last of them: the model follows a lasting fall in cost within a few frames, and
leaves behind the level that a stall too long to roll back has set.  Only frames that
traced pixels count: one the guard stopped before its first pixel says nothing about
their cost.

Deterministic: the controller reads no clock; everything it knows comes through
``FrameCost``.  Where the stages before and after tracing alone miss the budget, the
window is ``min_window`` and the plan is ``infeasible``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import RenderSettingsError
from ..focus.window import SHAPES
from .model import RAY_TYPES, CostFit, StageHistory, TraceCostModel
from .settings import ControllerSettings, FrameCost, WindowPlan
from .tiles import TileGrid

# The window search stops this close (relative) to the largest fitting fraction, or to the room.
_SEARCH_TOL = 3e-3


@dataclass
class _Snapshot:
    """What learning looked like before a surprising frame (for the roll-back)."""

    fit: CostFit
    before: StageHistory
    after: StageHistory
    fraction: float
    surprised: tuple[bool, bool, bool]  # trace, before, after


def largest_fitting(
    trace_at: Callable[[float], float],
    room: float,
    lo: float,
    hi: float,
    guess: float | None = None,
    known: dict[float, float] | None = None,
) -> float:
    """The largest fraction f in [lo, hi] with ``trace_at(f) <= room``, for a cost that grows
    with f (``lo`` when none fits), to a relative ``_SEARCH_TOL`` in f or in the cost.

    A bracketing root search on ``trace_at(f) = room``, from ``guess`` and the evaluations
    already ``known`` (fraction: cost).  Until it has a bracket it steps as if the cost
    went as a power of f: first the power 1, ``f * room / trace_at(f)`` (exact for a cost
    proportional to the area: the area form of Unreal's square-root rule), then the power
    through the last two tries.  Within a bracket it interpolates (the Illinois variant of
    regula falsi, aimed a little under ``room`` so it lands on the fitting side).  Each
    evaluation lays out a window, so this matters: 2 to 5 evaluations where bisection
    takes 12.
    """
    if room < 0.0:
        return lo
    aim = room * (1.0 - 0.5 * _SEARCH_TOL)
    fit: list[float] | None = None  # the bracket's ends: [fraction, cost, Illinois-scaled residual]
    fail: list[float] | None = None
    side = 0  # which end the last evaluation replaced: -1 the fitting one, +1 the failing one

    def add(f: float, t: float) -> None:
        nonlocal fit, fail, side
        if t <= room:
            if fit is not None and f <= fit[0]:
                return
            fit, moved = [f, t, t - aim], -1
        else:
            if fail is not None and f >= fail[0]:
                return
            fail, moved = [f, t, t - aim], 1
        if moved == side and fit is not None and fail is not None:
            (fail if moved < 0 else fit)[2] *= 0.5  # Illinois: the same end twice, halve the other's pull
        side = moved

    seen = dict(known or {})
    for f, t in seen.items():
        add(f, t)
    side = 0
    before: tuple[float, float] | None = None  # the try before the last, for the power step
    f = min(max(hi if guess is None else guess, lo), hi)
    for _ in range(64):
        if f not in seen:
            seen[f] = trace_at(f)
            add(f, seen[f])
        t = seen[f]
        if fit is not None and (fit[0] >= hi or fit[1] >= (1.0 - _SEARCH_TOL) * room):
            return fit[0]
        if fail is not None and fail[0] <= lo:
            return lo
        if fit is not None and fail is not None:
            width = fail[0] - fit[0]
            if width <= _SEARCH_TOL * fail[0]:
                return fit[0]
            f = fit[0] - fit[2] * width / (fail[2] - fit[2])
            f = min(max(f, fit[0] + 0.01 * width), fail[0] - 0.01 * width)
        elif t <= 0.0:
            f = hi
        else:
            power = 1.0
            if before is not None and before[1] > 0.0 and before[1] != t and before[0] != f:
                power = min(max(math.log(t / before[1]) / math.log(f / before[0]), 0.25), 4.0)
            ratio = min(max((aim / t) ** (1.0 / power), 0.25), 4.0)
            before = (f, t)
            f = min(max(f * max(ratio, 1.02) if t <= room else f * min(ratio, 0.98), lo), hi)
    return lo if fit is None else fit[0]


def _nearer_first(measured: float, first: float, second: float) -> bool:
    """Whether ``measured`` is nearer ``first`` than ``second`` as a ratio (on ``first``'s
    side of their geometric mean; ties go to ``first``)."""
    mid = math.sqrt(max(first, 0.0) * max(second, 0.0))
    return measured <= mid if first <= second else measured >= mid


def _real(value: object) -> bool:
    """A real number (not a bool)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _whole(value: object) -> bool:
    """A whole number (not a bool)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


class BudgetController:
    """Sizes the traced focus window of every frame to a frame-time budget.

    ``plan(gaze)`` before a frame, ``observe(cost)`` after it.  ``width x height`` is
    the screen, ``shape`` and ``feather_px`` the window's (as ``FocusWindow``);
    ``initial_fraction`` is the window of the frames planned before any was measured
    (default 0.1, clamped to the bounds).
    """

    def __init__(
        self,
        settings: ControllerSettings,
        width: int,
        height: int,
        shape: str = "circle",
        feather_px: float = 16.0,
        initial_fraction: float | None = None,
    ) -> None:
        settings.validate()
        if shape not in SHAPES:
            raise RenderSettingsError(f"window shape {shape!r} is not one of {', '.join(SHAPES)}")
        if not (_real(feather_px) and math.isfinite(feather_px) and feather_px >= 0.0):
            raise RenderSettingsError(f"window feather must be a finite number of pixels >= 0, got {feather_px!r}")
        if initial_fraction is not None and not (_real(initial_fraction) and 0.0 <= initial_fraction <= 1.0):
            raise RenderSettingsError(f"initial window fraction must be in [0, 1], got {initial_fraction!r}")
        self.settings = settings
        self.shape = shape
        self.feather_px = float(feather_px)
        self._initial = 0.1 if initial_fraction is None else float(initial_fraction)
        self._grid = TileGrid(1, 1, settings.tile_px)
        self._model = TraceCostModel(self._grid, settings)
        self.resize(width, height)
        self.reset()

    # -- set-up ---------------------------------------------------------------------------------------

    def resize(self, width: int, height: int) -> None:
        """A new screen size: the tile map and the non-trace history start again; the
        per-unit trace costs (per million pixels and rays) are kept."""
        if not (_whole(width) and _whole(height) and width > 0 and height > 0):
            raise RenderSettingsError(f"controller screen size must be positive whole numbers, got {width}x{height}")
        self.width, self.height = int(width), int(height)
        self._grid = TileGrid(self.width, self.height, self.settings.tile_px)
        self._model.grid = self._grid
        self._model.reset_tiles()
        self._before = StageHistory(self.settings.history_size, self.settings.history_weight)
        self._after = StageHistory(self.settings.history_size, self.settings.history_weight)
        self._snapshot: _Snapshot | None = None
        self._last: FrameCost | None = None
        self._over_budget = 0
        self._over_predicted = 0
        self._panic = False

    def reset(self) -> None:
        """Forget everything learnt (a scene cut): the next frames are warm-up frames again."""
        s = self.settings
        self._model.reset()
        self._before = StageHistory(s.history_size, s.history_weight)
        self._after = StageHistory(s.history_size, s.history_weight)
        self._fraction = min(max(self._initial, s.min_window), s.max_window)
        self._over_budget = 0
        self._over_predicted = 0
        self._panic = False
        self._observed = 0
        self._last = None
        self._snapshot = None

    # -- tiles ----------------------------------------------------------------------------------------

    @property
    def tile_shape(self) -> tuple[int, int]:
        """``(tiles_y, tiles_x)``: the shape ``FrameCost.tile_pixels`` must have."""
        return self._grid.shape

    @property
    def tile_px(self) -> int:
        """The side of a screen tile in pixels (the last row / column may be cut by the screen)."""
        return self._grid.tile_px

    def tile_coverage(self, gaze: tuple[float, float], fraction: float) -> np.ndarray:
        """(tiles_y, tiles_x) int64: the pixels a window at ``gaze`` of ``fraction`` covers in each tile
        (they sum to the window layout's exact ``count``), plus its ring's traced pixels with a ring."""
        layout = self._grid.layout(gaze, fraction, self.shape, self.feather_px)
        coverage = self._grid.counts(*layout.row_spans())
        ring = self.settings.ring
        return coverage if ring is None else coverage + self._grid.ring_counts(layout, ring)

    # -- what the model knows -------------------------------------------------------------------------

    @property
    def warmed_up(self) -> bool:
        """Whether any frame has been learnt from (before that, plans are warm-up plans)."""
        return self._model.fitted and bool(self._before.values)

    def tile_cost_ms(self) -> np.ndarray:
        """(tiles_y, tiles_x) predicted trace ms per traced pixel in each tile."""
        return self._model.pixel_cost().copy()

    def ray_costs_ms(self) -> dict[str, float]:
        """The fitted costs: fixed ms per frame, and ms per million pixels and per million rays of each type."""
        c = self._model.costs
        return {"overhead": float(c[0]), "pixel": float(c[1]), **{t: float(v) for t, v in zip(RAY_TYPES, c[2:])}}

    def predict(self, gaze: tuple[float, float], fraction: float) -> tuple[float, float]:
        """``(frame_ms, trace_ms)`` the model predicts for a window (NaN before warm-up)."""
        if not self.warmed_up:
            return float("nan"), float("nan")
        trace = self._model.predict(self.tile_coverage(gaze, fraction))
        return self._before.mean() + trace + self._after.mean(), trace

    # -- planning -------------------------------------------------------------------------------------

    def plan(self, gaze: tuple[float, float]) -> WindowPlan:
        """Before a frame: the window to trace at ``gaze`` and what it should cost."""
        s = self.settings
        budget = s.budget_ms
        if not self.warmed_up:
            return WindowPlan(self._fraction, math.nan, math.nan, budget, False, "warmup")
        before, after = self._before.mean(), self._after.mean()
        deadline = max(0.0, budget - after)
        cache: dict[float, float] = {}

        def trace_at(f: float) -> float:
            if f not in cache:
                if s.ring is None:
                    cache[f] = self._model.predict_spans(*self._grid.spans(gaze, f, self.shape, self.feather_px))
                else:  # the window and its ring, from the per-tile counts
                    cache[f] = self._model.predict(self.tile_coverage(gaze, f))
            return cache[f]

        def frame_at(f: float) -> float:
            return before + trace_at(f) + after

        lo_f, hi_f = s.min_window, s.max_window
        prev = self._fraction
        room = s.target_share * budget - before - after
        if not self._panic and self._holds(trace_at, prev, room, budget - before - after):
            return self._commit(prev, frame_at(prev), trace_at(prev), deadline, False, "hold")
        best = largest_fitting(trace_at, room, lo_f, hi_f, guess=prev, known=cache)
        if best <= lo_f and frame_at(lo_f) > budget:
            self._panic = False
            return self._commit(lo_f, frame_at(lo_f), trace_at(lo_f), deadline, True, "infeasible")
        if self._panic:
            self._panic = False
            f, reason = min(best, self._measured_fraction()), "panic"
        elif best <= prev:
            f, reason = best, "predict"
        else:
            base = max(prev, self._grid.tile_px**2 / (self.width * self.height))
            f = min(prev + s.increase_blend * (best - prev), base * (1.0 + s.max_growth), best)
            if best - f < s.change_threshold * prev:
                f = best  # the rest of the way is under the threshold: finish the step, not approach forever
            reason = "predict" if f == best else "grow"
        f = min(max(f, lo_f), hi_f)
        return self._commit(f, frame_at(f), trace_at(f), deadline, False, reason)

    def _holds(self, trace_at: Callable[[float], float], prev: float, room: float, budget_room: float) -> bool:
        """Whether the largest fitting window lies within the change threshold of ``prev`` (and
        ``prev`` still meets the budget), decided from two window layouts instead of a search."""
        s = self.settings
        band = s.change_threshold * prev
        if band <= 0.0 or not s.min_window <= prev <= s.max_window:
            return False
        t = trace_at(prev)
        if t <= room:  # the best is at or above prev: hold unless it is a threshold above
            up = min(prev + band, s.max_window)
            return up == prev or trace_at(up) > room
        # The best is below prev: hold if it is within the threshold and prev still meets the budget.
        down = max(prev - band, s.min_window)
        return t <= budget_room and down < prev and trace_at(down) <= room

    def _commit(
        self, f: float, frame: float, trace: float, deadline: float, infeasible: bool, reason: str
    ) -> WindowPlan:
        """Remember this frame's window and answer the plan."""
        self._fraction = f
        return WindowPlan(f, frame, trace, deadline, infeasible, reason)

    def _measured_fraction(self) -> float:
        """The window the last frame's measured cost per traced pixel allows within the target."""
        last = self._last
        if last is None or last.traced_pixels == 0:
            return self.settings.min_window
        per_pixel = last.trace_ms / last.traced_pixels
        room = self.settings.target_share * self.settings.budget_ms - last.before_trace_ms - last.after_trace_ms
        if per_pixel <= 0.0:
            return self.settings.max_window
        ring = self.settings.ring
        per_window_pixel = 1.0 if ring is None else ring.traced_per_window_pixel
        return max(room, 0.0) / (per_pixel * per_window_pixel * self.width * self.height)

    # -- learning -------------------------------------------------------------------------------------

    def observe(self, cost: FrameCost) -> None:
        """After a frame: learn from what it measured."""
        self._check(cost)
        self._observed += 1
        if self._observed <= self.settings.skip_frames:
            return
        s = self.settings
        pixels = float(np.sum(cost.tile_pixels))
        rays = np.asarray(cost.tile_rays, dtype=np.float64).reshape(-1, len(RAY_TYPES)).sum(axis=0)
        grow = 1.0 + s.surprise
        trace_up = before_up = after_up = trace_down = False
        predicted = 0.0
        snapshot, self._snapshot = self._snapshot, None
        if snapshot is not None and self._back_to(snapshot, cost, pixels, rays):
            # The last frame was a one-frame spike: forget it and go back to the window before it.
            self._model.restore(snapshot.fit)
            self._before, self._after = snapshot.before, snapshot.after
            self._fraction = snapshot.fraction
        elif self._model.fitted:
            predicted = self._model.predict_totals(pixels, rays)
            trace_up = cost.trace_ms > grow * predicted
            # only a frame that traced something can tell the trace is cheaper than predicted
            trace_down = pixels > 0.0 and grow * cost.trace_ms < predicted
            before_up = cost.before_trace_ms > grow * self._before.mean()
            after_up = cost.after_trace_ms > grow * self._after.mean()
            if trace_up or before_up or after_up:
                self._snapshot = _Snapshot(
                    self._model.fit.copy(),
                    self._before.copy(),
                    self._after.copy(),
                    self._fraction,
                    (trace_up, before_up, after_up),
                )
        # A surprising trace time re-levels the model (below) instead of entering the fit, where
        # the model has a level to scale: a stall in a frame the guard cut short would
        # otherwise read as a fixed cost there.
        self._model.learn(cost, fit=not (trace_up and predicted > 0.0))
        self._over_predicted = self._over_predicted + 1 if trace_down else 0
        if trace_up:
            self._relevel(cost, pixels, rays)
        elif self._over_predicted >= s.panic_frames:
            # A lasting fall in cost (or a re-level a stall left behind): down to this frame.
            self._over_predicted = 0
            self._relevel(cost, pixels, rays, down=True)
        (self._before.restart if before_up else self._before.add)(cost.before_trace_ms)
        (self._after.restart if after_up else self._after.add)(cost.after_trace_ms)
        self._over_budget = self._over_budget + 1 if cost.frame_ms > s.budget_ms else 0
        if self._over_budget >= s.panic_frames:
            # Unreal's panic: the next window is sized from this frame alone, the history restarts.
            self._panic = True
            self._over_budget = 0
            self._relevel(cost, pixels, rays)
            self._before.restart(cost.before_trace_ms)
            self._after.restart(cost.after_trace_ms)
            self._snapshot = None
        self._last = cost

    def _relevel(self, cost: FrameCost, pixels: float, rays: np.ndarray, down: bool = False) -> None:
        """Re-level the trace model so that it predicts this frame: what the frame's pixels and
        rays do not explain is a change of level (up where the fit still predicts less than
        the frame measured; with ``down``, down where it still predicts more)."""
        predicted = self._model.predict_totals(pixels, rays)
        if predicted > 0.0 and (0.0 < cost.trace_ms < predicted if down else cost.trace_ms > predicted):
            self._model.relevel(cost.trace_ms / predicted)

    def _back_to(self, snapshot: _Snapshot, cost: FrameCost, pixels: float, rays: np.ndarray) -> bool:
        """Whether a frame after a surprise fits the model from before it better than the
        re-levelled one, as a ratio, in every stage the surprise moved, and raises no new
        surprise in the others (the surprise was a one-frame spike).  A ratio, not a margin
        around the old prediction: after a stall the window is small, and there the fixed
        costs the model does not separate (launches, the pixel lists) can make the old
        prediction half the measurement while the re-levelled one is fifty times it."""
        grow = 1.0 + self.settings.surprise
        pairs = (
            (
                cost.trace_ms,
                self._model.predict_totals(pixels, rays, fit=snapshot.fit),
                self._model.predict_totals(pixels, rays),
            ),
            (cost.before_trace_ms, snapshot.before.mean(), self._before.mean()),
            (cost.after_trace_ms, snapshot.after.mean(), self._after.mean()),
        )
        for (measured, old, new), surprised in zip(pairs, snapshot.surprised):
            if not (_nearer_first(measured, old, new) if surprised else measured <= grow * old):
                return False
        return True

    def _check(self, cost: FrameCost) -> None:
        """Raise ``ValueError`` for a measurement the controller cannot learn from."""
        for name in ("frame_ms", "before_trace_ms", "trace_ms", "after_trace_ms"):
            value = float(getattr(cost, name))
            if not math.isfinite(value) or value < 0.0:
                raise ValueError(f"frame cost {name} must be a finite number of ms >= 0, got {value}")
        shape = self.tile_shape
        pixels, rays = np.asarray(cost.tile_pixels), np.asarray(cost.tile_rays)
        if pixels.shape != shape or rays.shape != (*shape, len(RAY_TYPES)):
            raise ValueError(
                f"frame cost tiles must be {shape} pixels and {(*shape, len(RAY_TYPES))} rays "
                f"(tile_shape at {self.width}x{self.height}), got {pixels.shape} and {rays.shape}"
            )
        if np.any(pixels < 0) or np.any(rays < 0):
            raise ValueError("frame cost tile pixel and ray counts must be >= 0")
