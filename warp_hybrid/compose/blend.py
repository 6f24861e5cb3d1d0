"""Composition: blend the traced layer over the raster image with the focus weights
(the compositing kernel's one Warp module).

Per pixel ``out = raster + weight * (traced - raster)``, selecting instead of
interpolating at the ends: exactly ``raster`` where ``weight <= 0`` (so whatever the
traced buffer holds outside the window, NaN included, never leaks in) and exactly
``traced`` where ``weight >= 1``.  ``out`` may be ``raster`` (blend in place).

The kernel follows ``Launcher.launch_pixels`` (last inputs ``row0, row_step, cols``):
one launch item per row on the CPU, one thread per pixel on CUDA.  It runs over the
rows the weights can be non-zero in (the focus window's bounding rows, its ring's with
``--ring``); the other rows of ``out`` are ``raster`` copied (a memory copy, the same
values the blend gives at weight 0), only where ``out`` may not hold it already: where
the raster layer was kept from the last frame, the rows the last blend wrote
(``FrameBuffers.color_rows``).
"""

from __future__ import annotations

import warp as wp

from ..core.passes import FrameContext, RenderPass
from ..core.rows import RowSpan, span_clip, span_minus, span_union
from ..parallel import Launcher
from ..timing import StageTimer

wp.set_module_options({"enable_backward": False})


@wp.kernel
def blend_pixels(
    raster: wp.array2d(dtype=wp.vec3),
    traced: wp.array2d(dtype=wp.vec3),
    weight: wp.array2d(dtype=wp.float32),
    out: wp.array2d(dtype=wp.vec3),
    row0: int,
    row_step: int,
    cols: int,
):
    """``out = lerp(raster, traced, weight)`` with exact ends."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, out.shape[1])):
        w = weight[y, x]
        base = raster[y, x]
        if w <= 0.0:
            out[y, x] = base
        elif w >= 1.0:
            out[y, x] = traced[y, x]
        else:
            out[y, x] = base + w * (traced[y, x] - base)


class Compositor(RenderPass):
    """Blends a traced layer over the raster image (the "compose" pass)."""

    def __init__(self, launcher: Launcher) -> None:
        """Launch the blend through ``launcher`` (rows split across its threads)."""
        self.launcher = launcher

    def execute(self, frame: FrameContext) -> None:
        """Blend ``frame``'s traced layer over its raster layer by the focus region's
        weights into the frame's colour."""
        assert frame.region is not None, "the focus pass runs first"
        b = frame.buffers
        rows = span_clip(frame.region.rows, b.height)
        cols = span_clip(frame.region.cols, b.width)
        stale = b.color_rows if frame.raster_cached else None
        stale_cols = b.color_cols if frame.raster_cached else None
        b.color_rows = b.color_cols = None  # until the blend is done
        self.blend(b.raster_color, b.traced_color, frame.region.weight, b.color, frame.timer, rows, stale)
        b.color_rows, b.color_cols = rows, cols
        # out differs from the raster layer only inside the window's columns, before and now
        frame.changed_rows = span_union(span_union(frame.changed_rows, stale), rows)
        frame.changed_cols = span_union(span_union(frame.changed_cols, stale_cols), cols)

    def blend(
        self,
        raster: wp.array,
        traced: wp.array,
        weight: wp.array,
        out: wp.array,
        timer: StageTimer,
        rows: RowSpan | None = None,
        stale_rows: RowSpan | None = None,
    ) -> None:
        """Write ``raster + weight * (traced - raster)`` into ``out`` (stage ``"compose"``).

        All arrays are (H, W): ``raster``, ``traced`` and ``out`` vec3, ``weight``
        float32; ``out`` may be ``raster``.  ``rows`` (first, stop): the only rows
        where ``weight`` may be > 0 (default: all); elsewhere ``out`` is ``raster``.
        ``stale_rows``: the only rows where ``out`` may differ from ``raster`` before the
        call (default: any row), the only ones outside ``rows`` copied."""
        shape = tuple(raster.shape)
        if len(shape) != 2:
            raise ValueError(f"raster must be an (H, W) image, got shape {shape}")
        for name, array in (("traced", traced), ("weight", weight), ("out", out)):
            if tuple(array.shape) != shape:
                raise ValueError(f"{name} has shape {tuple(array.shape)}, expected {shape} like raster")
        h, w = shape
        first, stop = (0, h) if rows is None else (max(0, min(rows[0], h)), max(0, min(rows[1], h)))
        stop = max(stop, first)
        with timer.stage("compose"):
            if out.ptr != raster.ptr:
                stale = (0, h) if stale_rows is None else span_clip(stale_rows, h)
                for a, b in span_minus(stale, (first, stop)):
                    wp.copy(out, raster, dest_offset=a * w, src_offset=a * w, count=(b - a) * w)
            if stop > first:
                views = [array[first:stop] for array in (raster, traced, weight, out)]
                self.launcher.launch_pixels(blend_pixels, stop - first, w, views)
