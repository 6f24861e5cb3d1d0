"""``SyntheticCost``: a deterministic stand-in for the renderer's clock, for tests and benchmarks.

A screen of per-pixel trace costs (ms per traced pixel) and per-pixel ray densities
(shadow, reflection, refraction rays per traced pixel), fixed costs for the stages
before and after tracing, optional cost spikes over frame ranges and optional
seeded jitter.  ``frame(plan, gaze)`` returns the ``FrameCost`` that tracing the plan's
window at ``gaze`` would measure: ``tile_pixels`` are the covered pixels per tile,
``tile_rays`` the covered ray densities summed per tile, ``trace_ms`` the covered
pixels' costs summed.  Coverage is the same ``FocusWindow`` layout the controller uses.
``SyntheticCost.glass_disc`` builds the usual test scene: a cheap background with an
expensive glass disc, whose per-pixel cost is the sum of its rays' costs.  ``run_loop``
closes the loop between a controller and a cost model over a sequence of gazes.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from .controller import BudgetController, largest_fitting
from .settings import FrameCost, WindowPlan
from .tiles import TileGrid, prefix_sums


@dataclass(frozen=True)
class Spike:
    """Costs scaled over the frames ``[start, stop)`` (``stop=None``: from ``start`` on);
    frames count ``SyntheticCost.frame`` calls from 0.

    ``stall_ms`` adds a fixed delay to the trace and ``traced_share`` keeps that share of
    the window's pixels and rays: a machine that stalls while tracing, and the budget
    guard that stops the window short at the deadline."""

    start: int
    stop: int | None = None
    trace_scale: float = 1.0
    before_scale: float = 1.0
    after_scale: float = 1.0
    stall_ms: float = 0.0
    traced_share: float = 1.0

    def active(self, frame: int) -> bool:
        """Whether the spike covers this frame."""
        return frame >= self.start and (self.stop is None or frame < self.stop)


class SyntheticCost:
    """A screen's trace costs and the fixed stage costs, as a cost model for the controller.

    ``pixel_ms``: (H, W) trace ms per traced pixel.  ``rays``: (H, W, 3) shadow,
    reflection and refraction rays per traced pixel.  ``before_ms``, ``after_ms``: the
    stages before and after tracing.  ``trace_fixed_ms``: what a frame that traces any
    pixel pays besides its pixels (kernel launches, the pixel lists; the renderer's is
    about a millisecond or two).  ``spikes``: frame ranges with scaled costs.
    ``jitter``: relative standard deviation of seeded Gaussian noise on each stage time.
    ``tile_px``, ``shape``, ``feather_px`` must match the controller's.
    """

    def __init__(
        self,
        pixel_ms: np.ndarray,
        rays: np.ndarray,
        before_ms: float,
        after_ms: float,
        *,
        tile_px: int = 32,
        shape: str = "circle",
        feather_px: float = 16.0,
        trace_fixed_ms: float = 0.0,
        spikes: Sequence[Spike] = (),
        jitter: float = 0.0,
        seed: int = 0,
    ) -> None:
        pixel_ms = np.asarray(pixel_ms, dtype=np.float64)
        rays = np.asarray(rays, dtype=np.float64)
        if pixel_ms.ndim != 2 or rays.shape != (*pixel_ms.shape, 3):
            raise ValueError(f"pixel_ms must be (H, W) and rays (H, W, 3), got {pixel_ms.shape} and {rays.shape}")
        self.height, self.width = pixel_ms.shape
        self.pixel_ms, self.rays = pixel_ms, rays
        self.before_ms, self.after_ms = float(before_ms), float(after_ms)
        self.trace_fixed_ms = float(trace_fixed_ms)
        self.shape, self.feather_px = shape, float(feather_px)
        self.spikes = tuple(spikes)
        self.jitter = float(jitter)
        self.grid = TileGrid(self.width, self.height, tile_px)
        self._cost_prefix = prefix_sums(pixel_ms)
        self._ray_prefix = prefix_sums(rays)
        self._rng = np.random.default_rng(seed)
        self.frame_index = 0

    @classmethod
    def glass_disc(
        cls,
        width: int = 640,
        height: int = 480,
        *,
        centre: tuple[float, float] = (0.75, 0.5),
        radius: float = 0.2,
        background_rays: tuple[float, float, float] = (1.0, 0.3, 0.0),
        glass_rays: tuple[float, float, float] = (2.0, 1.0, 3.0),
        pixel_cost_ms: float = 4e-5,
        ray_cost_ms: tuple[float, float, float] = (4e-5, 8e-5, 2e-4),
        before_ms: float = 8.0,
        after_ms: float = 2.0,
        **options,
    ) -> SyntheticCost:
        """A cheap background and an expensive glass disc of ``radius`` x the screen height
        centred at the normalised ``centre``; a pixel costs ``pixel_cost_ms`` plus its
        rays times ``ray_cost_ms``.  ``options`` go to the constructor."""
        px = np.arange(width) + 0.5
        py = (np.arange(height) + 0.5)[:, None]
        disc = (px - centre[0] * width) ** 2 + (py - centre[1] * height) ** 2 < (radius * height) ** 2
        rays = np.where(disc[..., None], np.asarray(glass_rays), np.asarray(background_rays))
        pixel_ms = pixel_cost_ms + rays @ np.asarray(ray_cost_ms, dtype=np.float64)
        return cls(pixel_ms, rays, before_ms, after_ms, **options)

    def trace_ms(self, gaze: tuple[float, float], fraction: float) -> float:
        """The noiseless, unspiked trace ms of a window."""
        start, stop = self.grid.spans(gaze, fraction, self.shape, self.feather_px)
        return self._trace_total(start, stop)

    def _trace_total(self, start: np.ndarray, stop: np.ndarray, share: float = 1.0) -> float:
        """``share`` of the covered pixels' costs summed, plus the fixed cost where any is covered."""
        fixed = self.trace_fixed_ms if np.any(stop > start) else 0.0
        return float(self.grid.sums(start, stop, self._cost_prefix).sum()) * share + fixed

    def best_fraction(self, gaze: tuple[float, float], target_ms: float, lo: float = 0.0, hi: float = 1.0) -> float:
        """The largest window in [lo, hi] whose noiseless, unspiked frame fits ``target_ms``."""
        room = target_ms - self.before_ms - self.after_ms
        return largest_fitting(lambda f: self.trace_ms(gaze, f), room, lo, hi)

    def frame(self, plan: WindowPlan | float, gaze: tuple[float, float]) -> FrameCost:
        """The ``FrameCost`` tracing ``plan``'s window (or a bare fraction) at ``gaze`` measures."""
        fraction = plan.fraction if isinstance(plan, WindowPlan) else float(plan)
        start, stop = self.grid.spans(gaze, fraction, self.shape, self.feather_px)
        tile_pixels = self.grid.counts(start, stop)
        tile_rays = np.rint(self.grid.sums(start, stop, self._ray_prefix)).astype(np.int64)
        scale = np.ones(3)
        stall_ms, share = 0.0, 1.0
        for spike in self.spikes:
            if spike.active(self.frame_index):
                scale *= (spike.trace_scale, spike.before_scale, spike.after_scale)
                stall_ms += spike.stall_ms
                share *= spike.traced_share
        if share < 1.0:  # the guard stopped the window short: its fixed cost is paid whole
            tile_pixels = np.rint(tile_pixels * share).astype(np.int64)
            tile_rays = np.rint(tile_rays * share).astype(np.int64)
        trace = self._trace_total(start, stop, share)
        if self.jitter > 0.0:
            scale *= np.maximum(1.0 + self.jitter * self._rng.standard_normal(3), 0.0)
        trace_ms, before_ms, after_ms = scale * (trace, self.before_ms, self.after_ms)
        trace_ms += stall_ms
        self.frame_index += 1
        return FrameCost(
            frame_ms=float(before_ms + trace_ms + after_ms),
            before_trace_ms=float(before_ms),
            trace_ms=float(trace_ms),
            after_trace_ms=float(after_ms),
            tile_pixels=tile_pixels,
            tile_rays=tile_rays,
        )


def run_loop(
    controller: BudgetController, cost: SyntheticCost, gazes: Iterable[tuple[float, float]]
) -> list[tuple[WindowPlan, FrameCost]]:
    """Close the loop: per gaze, ``controller.plan``, the frame ``cost`` measures, ``controller.observe``."""
    frames = []
    for gaze in gazes:
        plan = controller.plan(gaze)
        measured = cost.frame(plan, gaze)
        controller.observe(measured)
        frames.append((plan, measured))
    return frames


def fps_budget(fps: float) -> float:
    """The frame-time budget in ms of a frame rate."""
    if not (math.isfinite(fps) and fps > 0.0):
        raise ValueError(f"frame rate must be a positive number, got {fps}")
    return 1000.0 / fps
