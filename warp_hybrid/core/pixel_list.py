"""Pixel lists: compacted flat pixel indices ``row * width + column`` (the focus
region's pixels, every pixel for full ray tracing) that 1-D kernels walk."""

from __future__ import annotations

import warp as wp


@wp.func
def listed_pixel(pixels: wp.array(dtype=wp.int32), item: int, width: int, height: int) -> wp.vec2i:
    """(column, row) of entry ``item`` of a pixel list (flat indices ``row * width +
    column``); (-1, -1) for an entry outside the image, which the kernels skip."""
    pixel = pixels[item]
    if pixel < 0 or pixel >= width * height:
        return wp.vec2i(-1, -1)
    y = pixel // width
    return wp.vec2i(pixel - y * width, y)
