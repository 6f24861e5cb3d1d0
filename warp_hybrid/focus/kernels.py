"""The focus region kernel (one Warp module): per screen row, write the row's run of
traced pixel indices into the compacted list and the row's blend weights."""

from __future__ import annotations

import warp as wp

wp.set_module_options({"enable_backward": False})

SHAPE_CIRCLE = wp.constant(0)
SHAPE_RECT = wp.constant(1)
SHAPE_FULL = wp.constant(2)

# Smallest normal float32: the weight floor of a covered pixel.
MIN_WEIGHT = wp.constant(1.17549435e-38)


@wp.struct
class FocusGPU:
    """A window layout for the kernel.  ``left``/``top``/``right``/``bottom`` are the rect's
    seam edges, or +-1e30 where that edge is not a seam; ``hard`` means feather 0."""

    width: int
    shape: int
    cx: float
    cy: float
    radius: float
    left: float
    top: float
    right: float
    bottom: float
    inv_feather: float
    hard: int


@wp.func
def seam_distance(p: FocusGPU, px: float, py: float) -> float:
    """Distance from (px, py) inside the window to its seam (1e30 if it has none)."""
    if p.shape == SHAPE_CIRCLE:
        return p.radius - wp.length(wp.vec2(px - p.cx, py - p.cy))
    return wp.min(wp.min(px - p.left, p.right - px), wp.min(py - p.top, p.bottom - py))


@wp.kernel
def focus_rows(
    p: FocusGPU,
    spans: wp.array2d(dtype=wp.int32),
    pixels: wp.array(dtype=wp.int32),
    weight: wp.array2d(dtype=wp.float32),
    start: int,
    step: int,
):
    """Row ``j``: columns ``[spans[0, j], spans[1, j])`` are covered; their flat indices go
    to ``pixels[spans[2, j]:]``, their weights are smoothstep(seam distance / feather)
    floored at MIN_WEIGHT (1 if hard).  ``[spans[3, j], spans[4, j])`` were covered in
    the buffer's previous fill: their weights outside the new run are reset to 0 (the
    rest of the row is 0 already)."""
    j = start + wp.tid() * step
    a = spans[0, j]
    b = spans[1, j]
    first = spans[2, j] - a
    for x in range(spans[3, j], wp.min(a, spans[4, j])):
        weight[j, x] = 0.0
    for x in range(wp.max(b, spans[3, j]), spans[4, j]):
        weight[j, x] = 0.0
    py = float(j) + 0.5
    for x in range(a, b):
        pixels[first + x] = j * p.width + x
        w = 1.0
        if p.hard == 0:
            t = wp.clamp(seam_distance(p, float(x) + 0.5, py) * p.inv_feather, 0.0, 1.0)
            w = wp.max(t * t * (3.0 - 2.0 * t), MIN_WEIGHT)
        weight[j, x] = w


@wp.kernel
def list_runs(runs: wp.array2d(dtype=wp.int32), width: int, pixels: wp.array(dtype=wp.int32), start: int, step: int):
    """Run ``i``: row ``runs[0, i]``, columns ``[runs[1, i], runs[2, i])`` -> their flat
    indices at ``pixels[runs[3, i]:]`` (empty runs write nothing)."""
    i = start + wp.tid() * step
    row = runs[0, i]
    a = runs[1, i]
    first = runs[3, i] - a
    for x in range(a, runs[2, i]):
        pixels[first + x] = row * width + x
