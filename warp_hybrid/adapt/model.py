"""The trace cost model and the history of the stages the window does not drive.

Trace cost.  A frame's trace time is modelled as

    trace_ms ~ c0 + c_pix * pixels + c_shadow * shadow_rays + c_refl * reflection_rays + c_refr * refraction_rays

(pixels and rays in millions, so the costs are ms per million and do not depend on
the resolution; ``c0`` is a fixed per-frame overhead such as kernel launches, which
would otherwise make small windows look expensive per pixel).  The costs ``c >= 0``
are fitted to every frame's measured totals by least squares with forgetting, solved
exactly each frame from the weighted normal equations as a 5 x 5 non-negative least
squares problem (Lawson and Hanson's active set).  The forgetting is directional
(Kulhavy): a new frame forgets ``1 - cost_forgetting`` of the information only along the
direction it measures again, not in the others.  Plain exponential forgetting (RLS with
a forgetting factor) would, under a steady gaze that sends nearly the same mix of rays
frame after frame, forget what the glass cost while the gaze rested on the background,
and wind up its covariance in the unexcited directions.  A prior decides what the frames
cannot tell apart (a cost type that never varied): "a traced pixel and every ray cost
the same" with ``cost_prior`` times one frame's information, and "no fixed overhead"
with ``OVERHEAD_PRIOR`` (one frame's information: an overhead needs several frames of
evidence, so that a cost jump that coincides with a window change is not taken for one).

Where the cost lies.  Per screen tile the model keeps exponentially weighted rays
per traced pixel of each type, from ``tile_rays / tile_pixels`` of the frames that
traced the tile (weighted by the pixels traced, so a tile the window only grazed
counts little).  A tile never traced starts from a prior: its traced neighbours'
rays per pixel (a 3 x 3 normalised convolution), else the mean of every traced
tile; the prior weighs ``prior_pixels`` traced pixels, so it fades as the tile is
traced.  The predicted cost of a traced pixel in tile t is then
``c_pix + rays_per_pixel(t) . (c_shadow, c_refl, c_refr)``, and a window's predicted
trace time is ``c0 + sum_t coverage(t) * cost(t)``: glass the window has seen is
expensive before the gaze lands on it.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from .settings import ControllerSettings, FrameCost
from .tiles import TileGrid

RAY_TYPES = ("shadow", "reflection", "refraction")

# Pixels and rays enter the fit in millions.
UNIT = 1.0e6

# Weight of the prior "no fixed trace overhead", in frames' information.
OVERHEAD_PRIOR = 1.0

# Regressor columns: overhead, pixels, then one per ray type.
_N = 2 + len(RAY_TYPES)


@dataclass
class CostFit:
    """The weighted normal equations of the trace-cost fit: ``A = sum w x x^T``, ``b = sum w x y``."""

    a: np.ndarray
    b: np.ndarray
    frame_info: np.ndarray  # exponentially weighted mean of diag(x x^T): one frame's information
    frames: int = 0

    @classmethod
    def empty(cls) -> CostFit:
        """No frame yet."""
        return cls(np.zeros((_N, _N)), np.zeros(_N), np.zeros(_N))

    def copy(self) -> CostFit:
        """An independent copy."""
        return CostFit(self.a.copy(), self.b.copy(), self.frame_info.copy(), self.frames)


def regressors(pixels: float, rays: np.ndarray) -> np.ndarray:
    """The fit's regressor vector for a frame that traced ``pixels`` and ``rays`` (3,)."""
    return np.concatenate(([1.0, pixels / UNIT], np.asarray(rays, dtype=np.float64) / UNIT))


def solve_costs(fit: CostFit, prior: float) -> np.ndarray:
    """The non-negative costs minimising the weighted squared error plus the prior."""
    a = fit.a
    reg = np.zeros((_N, _N))
    ray_info = max(float(np.mean(fit.frame_info[1:])), 1e-300)
    equal = np.eye(_N - 1) - 1.0 / (_N - 1)  # penalises unequal pixel and ray costs
    reg[1:, 1:] = prior * ray_info * equal
    reg[0, 0] = OVERHEAD_PRIOR * max(float(fit.frame_info[0]), 1e-300)  # overhead towards 0
    m = a + reg + 1e-12 * (np.trace(a) + 1e-300) * np.eye(_N)
    try:
        c = np.linalg.solve(m, fit.b)
    except np.linalg.LinAlgError:
        c = -np.ones(_N)
    return c if np.all(c >= 0.0) else _nnls_normal(m, fit.b)


def _nnls_normal(m: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Lawson and Hanson's active-set NNLS on the normal equations: ``min c.M.c - 2 b.c`` with ``c >= 0``."""
    n = len(b)
    c = np.zeros(n)
    free = np.zeros(n, dtype=bool)
    tol = 1e-12 * max(float(np.abs(b).max()), 1e-300)
    for _ in range(4 * n):
        gradient = b - m @ c
        candidates = np.where(free, -np.inf, gradient)
        j = int(np.argmax(candidates))
        if candidates[j] <= tol:
            break
        free[j] = True
        while True:
            z = np.zeros(n)
            idx = np.flatnonzero(free)
            try:
                z[idx] = np.linalg.solve(m[np.ix_(idx, idx)], b[idx])
            except np.linalg.LinAlgError:
                z[idx] = np.linalg.lstsq(m[np.ix_(idx, idx)], b[idx], rcond=None)[0]
            if np.all(z[idx] > 0.0):
                break
            neg = free & (z <= 0.0)
            step = float(np.min(c[neg] / (c[neg] - z[neg])))
            c = c + step * (z - c)
            free &= c > tol
            if not free.any():
                z = np.zeros(n)
                break
        c = z
    return c


class TraceCostModel:
    """Per-unit trace costs (fitted from frame totals) and rays per pixel by screen tile."""

    def __init__(self, grid: TileGrid, settings: ControllerSettings) -> None:
        self.grid = grid
        self.settings = settings
        self.fit = CostFit.empty()
        self.costs = np.zeros(_N)
        self.reset_tiles()

    def reset_tiles(self) -> None:
        """Forget what was learnt about the tiles (a new resolution or scene)."""
        ty, tx = self.grid.shape
        self._tile_px = np.zeros((ty, tx))
        self._tile_rays = np.zeros((ty, tx, len(RAY_TYPES)))
        self._tile_seen = np.zeros((ty, tx))  # pixels ever traced (not forgotten): the estimate's weight
        self._pixel_cost: np.ndarray | None = None
        self._cost_cum: np.ndarray | None = None

    def reset(self) -> None:
        """Forget everything."""
        self.fit = CostFit.empty()
        self.costs = np.zeros(_N)
        self.reset_tiles()

    @property
    def fitted(self) -> bool:
        """Whether any frame has been learnt from."""
        return self.fit.frames > 0

    def predict_totals(self, pixels: float, rays: np.ndarray, fit: CostFit | None = None) -> float:
        """Predicted trace ms of a frame that traces ``pixels`` and ``rays`` in total
        (with the current fit, or with ``fit``)."""
        costs = self.costs if fit is None else solve_costs(fit, self.settings.cost_prior)
        return float(costs @ regressors(pixels, rays))

    def relevel(self, factor: float) -> None:
        """Scale every past measurement by ``factor`` (the fitted costs scale with it)."""
        self.fit.b *= factor
        self.costs = solve_costs(self.fit, self.settings.cost_prior)
        self._pixel_cost = None

    def restore(self, fit: CostFit) -> None:
        """Go back to an earlier fit (see ``CostFit.copy``)."""
        self.fit = fit.copy()
        self.costs = solve_costs(self.fit, self.settings.cost_prior)
        self._pixel_cost = None

    def learn(self, cost: FrameCost, fit: bool = True) -> None:
        """Add one frame's measurements: its totals to the fit (unless not ``fit``: a frame
        that tells a change of level, not where the cost lies), its rays per pixel to the
        tiles."""
        pixels = np.asarray(cost.tile_pixels, dtype=np.float64)
        rays = np.asarray(cost.tile_rays, dtype=np.float64)
        if fit:
            self._fit_totals(pixels.sum(), rays.reshape(-1, len(RAY_TYPES)).sum(axis=0), float(cost.trace_ms))
        # A tile traced in full forgets tile_forgetting of its past; one traced in part, less.
        keep = self.settings.tile_forgetting ** (pixels / self.grid.tile_area)
        self._tile_px = self._tile_px * keep + pixels
        self._tile_rays = self._tile_rays * keep[..., None] + rays
        self._tile_seen += pixels
        self._pixel_cost = None

    def _fit_totals(self, pixels: float, rays: np.ndarray, trace_ms: float) -> None:
        """Add a frame's totals to the fit and solve it again."""
        x = regressors(pixels, rays)
        # Directional forgetting (Kulhavy): forget (1 - lam) of the information along the
        # direction this frame measures again, keep the rest; the estimate is unchanged.
        a, b = self.fit.a, self.fit.b
        u = a @ x
        q = float(x @ u)
        if q > 1e-12 * max(float(np.trace(a)), 1e-300) * float(x @ x):
            alpha = (1.0 - self.settings.cost_forgetting) / q
            a = a - alpha * np.outer(u, u)
            b = b - alpha * u * float(x @ b)
        self.fit.a = 0.5 * (a + a.T) + np.outer(x, x)
        self.fit.b = b + x * trace_ms
        lam = self.settings.cost_forgetting
        self.fit.frame_info = x * x if self.fit.frames == 0 else lam * self.fit.frame_info + (1.0 - lam) * x * x
        self.fit.frames += 1
        self.costs = solve_costs(self.fit, self.settings.cost_prior)

    def rays_per_pixel(self) -> np.ndarray:
        """(tiles_y, tiles_x, 3) estimated rays per traced pixel of each type, priors included."""
        w, r = self._tile_px, self._tile_rays
        total = w.sum()
        if total <= 0.0:
            return np.zeros_like(r)
        global_mean = r.reshape(-1, len(RAY_TYPES)).sum(axis=0) / total
        wn, rn = _box3(w), _box3(r)
        with np.errstate(divide="ignore", invalid="ignore"):
            prior = np.where((wn > 0.0)[..., None], rn / wn[..., None], global_mean)
        with np.errstate(divide="ignore", invalid="ignore"):
            own = np.where((w > 0.0)[..., None], r / w[..., None], prior)
        seen, k = self._tile_seen[..., None], self.settings.prior_pixels
        return (seen * own + k * prior) / (seen + k)

    def pixel_cost(self) -> np.ndarray:
        """(tiles_y, tiles_x) predicted trace ms per traced pixel of each tile."""
        if self._pixel_cost is None:
            self._pixel_cost = (self.costs[1] + self.rays_per_pixel() @ self.costs[2:]) / UNIT
            # Per tile row, the prefix sums of the cost over the screen's columns, flattened.
            per_column = np.repeat(self._pixel_cost, self.grid.tile_px, axis=1)[:, : self.grid.width]
            self._cost_cum = np.pad(np.cumsum(per_column, axis=1), ((0, 0), (1, 0))).ravel()
        return self._pixel_cost

    def predict(self, coverage: np.ndarray) -> float:
        """Predicted trace ms of a window covering ``coverage`` (tiles_y, tiles_x) pixels."""
        if not np.any(coverage):
            return 0.0
        return float(self.costs[0] + np.sum(coverage * self.pixel_cost()))

    def predict_spans(self, start: np.ndarray, stop: np.ndarray) -> float:
        """``predict`` for a window given by its per-row column runs ``[start, stop)``: the
        same number in O(H), from per-tile-row prefix sums of the cost over the columns."""
        self.pixel_cost()
        base = self.grid.row_offsets
        covered = np.take(self._cost_cum, base + stop) - np.take(self._cost_cum, base + start)
        if not np.any(stop > start):
            return 0.0
        return float(self.costs[0] + covered.sum())


def _box3(values: np.ndarray) -> np.ndarray:
    """Sum over each tile's 3 x 3 neighbourhood (zero outside the screen), first two axes."""
    pad = [(1, 1), (1, 1)] + [(0, 0)] * (values.ndim - 2)
    p = np.pad(values, pad)
    h, w = values.shape[:2]
    return sum(p[dy : dy + h, dx : dx + w] for dy in range(3) for dx in range(3))


class StageHistory:
    """Unreal's weighted frame history for one stage time: the newest frame weighs 1,
    each older one ``weight`` times the next, at most ``size`` frames."""

    def __init__(self, size: int, weight: float) -> None:
        self.weight = weight
        self.values: deque[float] = deque(maxlen=size)

    def add(self, value: float) -> None:
        """Append the newest frame's time."""
        self.values.append(float(value))

    def restart(self, value: float) -> None:
        """Drop the history and start again from this frame (a history reset)."""
        self.values.clear()
        self.values.append(float(value))

    def mean(self) -> float:
        """The weighted mean (NaN when empty)."""
        if not self.values:
            return float("nan")
        w = self.weight ** np.arange(len(self.values))[::-1]
        return float(np.dot(w, np.fromiter(self.values, dtype=np.float64)) / w.sum())

    def copy(self) -> StageHistory:
        """An independent copy."""
        other = StageHistory(self.values.maxlen or 1, self.weight)
        other.values.extend(self.values)
        return other
