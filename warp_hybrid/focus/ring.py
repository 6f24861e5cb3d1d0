"""The mid-resolution ring (``--ring``): traced at every ``step``-th pixel around the window.

Between the full-rate focus window and the raster periphery, an annulus from the
window's boundary out to ``scale`` times its half extents (the same shape, about the
window's clamped centre, cut by the screen) is traced on a lattice of every ``step``-th
column and row, anchored at the screen's top-left pixel: pixel (x, y) of the ring is
traced when ``x % step == 0 and y % step == 0`` (so the lattice does not crawl when the
window moves).  The ring's traced pixels are appended to the window's pixel list
(window first, in the usual row-major order, then the ring's lattice pixels, row-major),
so the tracer, the ray tally, the budget guard (which traces the ring last, after the
window's own rings, so a deadline cuts the ring first) and the budget controller's cost
model count them like any other traced pixel.  ``compose.upsample`` fills the ring's
other pixels from the lattice, guided by the G-buffer.

The blend weights of a ringed region are those of the outer shape (``focus.region``'s
rule: ``smoothstep(0, feather, d)`` of the distance ``d`` to the ring's outer seam): 1 in
the window and the ring's inner part, falling to 0 across the feather band inside the
ring's outer boundary.  Quality therefore falls in steps of sampling rate (every pixel,
every ``step``-th, none) with the smooth blend at the outer edge only.

This module is the ring's geometry (the budget controller sizes the ring with it too);
``focus.ring_builder.RingedFocusBuilder`` is the focus pass with a ring.  Without
``--ring`` the plain ``FocusRegionBuilder`` runs and no ring kernel is compiled.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import RenderSettingsError
from .region import ring_runs
from .window import WindowLayout, placed

#: The ring's outer extent, in window half extents: (1, MAX_RING_SCALE].
MAX_RING_SCALE = 8.0
#: The lattice steps a ring may be traced at (every 2nd .. every 8th pixel).
MIN_RING_STEP, MAX_RING_STEP = 2, 8


@dataclass(frozen=True)
class RingSpec:
    """How the ring is sized: out to ``scale`` x the window's half extents, traced at
    every ``step``-th pixel in x and y."""

    scale: float = 2.0
    step: int = 2

    def validate(self) -> None:
        """Raise ``RenderSettingsError`` for a scale outside (1, MAX_RING_SCALE] or a step
        outside MIN_RING_STEP..MAX_RING_STEP."""
        scale, step = self.scale, self.step
        if isinstance(scale, bool) or not isinstance(scale, numbers.Real) or not 1.0 < scale <= MAX_RING_SCALE:
            raise RenderSettingsError(
                f"ring scale must be a number in (1, {MAX_RING_SCALE:g}] (window half extents), got {scale!r}"
            )
        if (
            isinstance(step, bool)
            or not isinstance(step, numbers.Integral)
            or not MIN_RING_STEP <= step <= MAX_RING_STEP
        ):
            raise RenderSettingsError(
                f"ring step must be a whole number in {MIN_RING_STEP}..{MAX_RING_STEP} (pixels), got {step!r}"
            )

    @property
    def traced_per_window_pixel(self) -> float:
        """Pixels traced per window pixel, the ring's included, where the screen cuts
        neither: ``1 + (scale^2 - 1) / step^2`` (the annulus's area over the lattice's)."""
        return 1.0 + (self.scale**2 - 1.0) / self.step**2

    def outer(self, window: WindowLayout) -> WindowLayout | None:
        """The ring's outer shape around a placed ``window`` (its feather too), or None
        where the window has no ring: a full-screen or an empty window."""
        if window.shape == "full" or window.count == 0:
            return None
        return placed(
            window.shape,
            window.width,
            window.height,
            window.cx,
            window.cy,
            window.half_width * self.scale,
            window.half_height * self.scale,
            window.feather_px,
        )


def lattice_runs(window: WindowLayout, outer: WindowLayout, step: int) -> tuple[np.ndarray, int]:
    """The pixels a ringed window traces, as runs: (5, n) int32 rows (row, first column,
    stop, offset in the pixel list, column stride), the window's own first (every pixel,
    row-major, as ``FocusRegionBuilder`` lists them), then the ring's: per lattice row
    (``row % step == 0``) the outer span less the window's, from its first lattice column
    (``% step == 0``) in strides of ``step``; and the list's length."""
    runs, _ = ring_runs([window, outer])
    h = window.height
    # ring_runs lists each ring's left runs, then its right runs: interleave the ring's per row.
    order = np.concatenate([np.arange(2 * h), np.stack([np.arange(2 * h, 3 * h), np.arange(3 * h, 4 * h)], 1).ravel()])
    runs = runs[:, order]
    rows, first, stop = runs[0].astype(np.int64), runs[1].astype(np.int64), runs[2].astype(np.int64)
    stride = np.ones_like(rows)
    ring = slice(2 * h, None)  # ring_runs' second ring: the outer shape less the window
    stride[ring] = step
    first[ring] = -(-first[ring] // step) * step
    lengths = -(-(stop - first) // stride)
    lengths[ring][rows[ring] % step != 0] = 0
    lengths = np.maximum(lengths, 0)
    offsets = np.cumsum(lengths) - lengths
    table = np.vstack([rows, first, stop, offsets, stride])
    return np.ascontiguousarray(table.astype(np.int32)), int(lengths.sum())


@dataclass
class RingLayout:
    """A ring placed on the screen around a region's window: its ``outer`` shape, the
    lattice ``step``, the ring's traced pixel count ``count`` (its lattice pixels, which
    follow the window's in the region's list) and ``spans``: a (4, H) int32 device array
    per row of the outer span's start and stop and the window's (the upsampler's input)."""

    outer: WindowLayout
    step: int
    count: int
    spans: Any
