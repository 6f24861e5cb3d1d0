"""Screen tiles and the pixels a focus window covers in each.

The controller learns and predicts trace cost per screen tile (``tile_px`` square,
the last row and column of tiles cut by the screen edge).  The window's coverage is
taken from ``FocusWindow.layout(...).row_spans()``: per screen row one run of covered
columns ``[start, stop)``, so the pixels a row covers in tile column ``tx`` are the
run clipped to the tile's columns, ``clip(stop) - clip(start)``; rows are then
summed into tile rows with ``np.add.reduceat``.  The same clipping, applied to
per-row prefix sums of a per-pixel map, sums that map over the covered pixels of
each tile (``TileGrid.sums``, used by the synthetic cost model).  Everything is
vectorised over (rows x tile columns): O(H * tiles_x) per call, no per-pixel work.
"""

from __future__ import annotations

import numpy as np

from ..focus.ring import RingSpec
from ..focus.window import FocusWindow, WindowLayout


class TileGrid:
    """``width x height`` pixels cut into ``tile_px`` square tiles, row 0 at the top."""

    def __init__(self, width: int, height: int, tile_px: int) -> None:
        self.width, self.height, self.tile_px = int(width), int(height), int(tile_px)
        self.tiles_x = -(-self.width // self.tile_px)
        self.tiles_y = -(-self.height // self.tile_px)
        edges = np.minimum(np.arange(self.tiles_x + 1) * self.tile_px, self.width)
        self._col_lo = edges[:-1].astype(np.int64)
        self._col_hi = edges[1:].astype(np.int64)
        self._row_starts = np.arange(0, self.height, self.tile_px)
        # Offsets of each screen row's tile row in a flattened (tiles_y, width + 1) table.
        self.row_offsets = (np.arange(self.height) // self.tile_px) * (self.width + 1)
        rows = np.minimum(np.arange(self.tiles_y + 1) * self.tile_px, self.height)
        cols = edges
        # Pixels per tile (the edge tiles are cut by the screen).
        self.tile_area = np.diff(rows)[:, None] * np.diff(cols)[None, :]

    @property
    def shape(self) -> tuple[int, int]:
        """``(tiles_y, tiles_x)``."""
        return self.tiles_y, self.tiles_x

    def layout(self, gaze: tuple[float, float], fraction: float, shape: str, feather_px: float) -> WindowLayout:
        """A window at ``gaze`` placed on this screen."""
        window = FocusWindow(gaze=gaze, fraction=fraction, shape=shape, feather_px=feather_px)
        return window.layout(self.width, self.height)

    def spans(self, gaze: tuple[float, float], fraction: float, shape: str, feather_px: float):
        """Per screen row the covered columns ``[start, stop)`` of a window at ``gaze``."""
        return self.layout(gaze, fraction, shape, feather_px).row_spans()

    def _clipped(self, start: np.ndarray, stop: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(H, tiles_x) covered column runs clipped to each tile column (``lo <= hi``)."""
        lo = np.clip(start[:, None], self._col_lo, self._col_hi)
        hi = np.clip(stop[:, None], self._col_lo, self._col_hi)
        return lo, np.maximum(hi, lo)

    def counts(self, start: np.ndarray, stop: np.ndarray) -> np.ndarray:
        """(tiles_y, tiles_x) int64: covered pixels per tile."""
        lo, hi = self._clipped(start, stop)
        return np.add.reduceat(hi - lo, self._row_starts, axis=0)

    def lattice_counts(self, start: np.ndarray, stop: np.ndarray, step: int) -> np.ndarray:
        """(tiles_y, tiles_x) int64: covered pixels per tile on the lattice of every
        ``step``-th column and row (``x % step == 0 == y % step``, ``focus.ring``)."""
        lo, hi = self._clipped(start, stop)
        n = -(-hi // step) - (-(-lo // step))
        n[np.arange(self.height) % step != 0] = 0
        return np.add.reduceat(n, self._row_starts, axis=0)

    def ring_counts(self, window: WindowLayout, ring: RingSpec) -> np.ndarray:
        """(tiles_y, tiles_x) int64: the traced pixels per tile of ``window``'s ring
        (its lattice pixels between the window and the outer shape)."""
        outer = ring.outer(window)
        if outer is None:
            return np.zeros(self.shape, dtype=np.int64)
        return self.lattice_counts(*outer.row_spans(), ring.step) - self.lattice_counts(*window.row_spans(), ring.step)

    def sums(self, start: np.ndarray, stop: np.ndarray, prefix: np.ndarray) -> np.ndarray:
        """Per tile, the sum of a per-pixel map over the covered pixels.

        ``prefix`` is ``prefix_sums(map)``: (H, W + 1[, C]) per-row prefix sums with a
        leading zero column; the result is (tiles_y, tiles_x[, C]).
        """
        lo, hi = self._clipped(start, stop)
        flat = prefix.reshape(self.height * (self.width + 1), -1)
        base = (np.arange(self.height) * (self.width + 1))[:, None]
        per_row = np.take(flat, base + hi, axis=0) - np.take(flat, base + lo, axis=0)
        sums = np.add.reduceat(per_row, self._row_starts, axis=0)
        return sums.reshape(sums.shape[:2] + prefix.shape[2:])


def prefix_sums(values: np.ndarray) -> np.ndarray:
    """(H, W[, C]) map -> (H, W + 1[, C]) float64 per-row prefix sums, leading zero column."""
    values = np.asarray(values, dtype=np.float64)
    pad = [(0, 0), (1, 0)] + [(0, 0)] * (values.ndim - 2)
    return np.pad(np.cumsum(values, axis=1), pad)
