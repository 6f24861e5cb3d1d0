"""Ray counts by screen tile, summed on the device and read once after the frame.

The tracing kernels leave per-item ray counts (shadow rays from the primary point and
from secondary hits, reflection and refraction rays) in the tracer's scratch rows;
``tally_tiles`` adds them into a small (slots, tiles, 4) table: pixels traced, shadow,
reflection and refraction rays per ``TILE_PX`` tile.  On the CPU each launch piece
(host thread) owns one slot (``Launcher.launch_slots``), since Warp's CPU atomics are plain read-modify-writes; on
CUDA one piece covers every item and the adds are atomic.  A frame reads the table
once, after its image (``RayTally.counts`` for the totals, ``RayTally.tiles`` for the
budget controller's cost map), so nothing inside a frame waits on the host.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

#: Side of a screen tile in pixels (the budget controller's cost map uses the same tiles).
TILE_PX = wp.constant(32)
#: The tally's columns per tile.
TALLY_COLUMNS = ("pixels", "shadow", "reflection", "refraction")


#: The fewest items a band of the tally holds on the CPU: an item costs a few ns, a
#: launch tens of us, so a list of up to this many goes out in one band per thread.
TALLY_BAND_ITEMS = 1 << 16


# The tally's loop over a run of items: the pixel's row is computed only when the
# pixel leaves the last one's (lists run along rows), not by a division per item.
_TALLY_RUN_CPP = f"""
const int* list = pixels.data;
const int columns = (int)counts.shape[1];
int* slot_table = (int*)((char*)tally.data + (size_t)slot * tally.strides[0]);
const int tile_row = (int)(tally.strides[1] / sizeof(int));
const int total = width * height;
int row_start = 0;
int y = 0;
for (int item = first; item < last; ++item) {{
    const int pixel = list[item];
    if (pixel < 0 || pixel >= total) continue;
    if (pixel < row_start || pixel - row_start >= width) {{
        y = pixel / width;
        row_start = y * width;
    }}
    const int tile = (y / {int(TILE_PX)}) * tiles_x + (pixel - row_start) / {int(TILE_PX)};
    int* t = slot_table + (size_t)tile * tile_row;
    const int* c = counts.data + (size_t)item * columns;
    wp::atomic_add(t, 1);
    wp::atomic_add(t + 1, c[0] + c[1]);
    wp::atomic_add(t + 2, c[2]);
    wp::atomic_add(t + 3, c[3]);
}}
"""


@wp.func_native(_TALLY_RUN_CPP)
def _tally_run(
    pixels: wp.array(dtype=wp.int32),
    counts: wp.array2d(dtype=wp.int32),
    width: int,
    height: int,
    tiles_x: int,
    tally: wp.array3d(dtype=wp.int32),
    slot: int,
    first: int,
    last: int,
):
    """Items ``first <= item < last`` into tally slot ``slot`` (``_TALLY_RUN_CPP``; the
    arrays are contiguous)."""
    ...


@wp.kernel
def tally_tiles(
    pixels: wp.array(dtype=wp.int32),
    counts: wp.array2d(dtype=wp.int32),
    width: int,
    height: int,
    tiles_x: int,
    tally: wp.array3d(dtype=wp.int32),
    slot: int,
    start: int,
    stop: int,
    group: int,
):
    """The items of this launch item's group of a traced pixel list into tally slot ``slot``."""
    first = start + wp.tid() * group
    _tally_run(pixels, counts, width, height, tiles_x, tally, slot, first, wp.min(first + group, stop))


@dataclass
class RayCounts:
    """Rays launched in a frame (logical rays: a shadow ray stepping through several
    transparent surfaces counts once); ``traced_pixels`` counts the listed items."""

    traced_pixels: int
    shadow: int
    reflection: int
    refraction: int

    def to_dict(self) -> dict[str, int]:
        """JSON-ready counts."""
        return {
            "traced_pixels": self.traced_pixels,
            "shadow": self.shadow,
            "reflection": self.reflection,
            "refraction": self.refraction,
        }


@dataclass
class TileCounts:
    """A frame's tally per screen tile: ``pixels`` (tiles_y, tiles_x) traced pixels and
    ``rays`` (tiles_y, tiles_x, 3) shadow, reflection and refraction rays."""

    pixels: np.ndarray
    rays: np.ndarray


class RayTally:
    """The device table of one frame's ray counts by tile (see the module docstring)."""

    def __init__(self, width: int, height: int, slots: int, device: wp.context.Device) -> None:
        """A cleared table for a ``width`` x ``height`` screen and ``slots`` launch pieces."""
        self.width = width
        self.height = height
        self.tiles_y = -(-height // TILE_PX)
        self.tiles_x = -(-width // TILE_PX)
        self.table = wp.zeros((slots, self.tiles_y * self.tiles_x, len(TALLY_COLUMNS)), dtype=wp.int32, device=device)
        self.items = 0

    def clear(self) -> None:
        """Start a new frame."""
        self.table.zero_()
        self.items = 0

    def _summed(self) -> np.ndarray:
        return self.table.numpy().sum(axis=0, dtype=np.int64)

    def counts(self) -> RayCounts:
        """The frame's totals (reads the table: call after the frame)."""
        totals = self._summed().sum(axis=0)
        return RayCounts(self.items, int(totals[1]), int(totals[2]), int(totals[3]))

    def tiles(self) -> TileCounts:
        """The frame's counts per tile (reads the table: call after the frame)."""
        per_tile = self._summed().reshape(self.tiles_y, self.tiles_x, len(TALLY_COLUMNS))
        return TileCounts(per_tile[..., 0], per_tile[..., 1:])
