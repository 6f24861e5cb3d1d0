"""Pixel lists: compacted flat pixel indices ``row * width + column`` (the focus
region's pixels, every pixel for full ray tracing) that 1-D kernels walk."""

from __future__ import annotations

import warp as wp


@wp.func
def listed_pixel(pixels: wp.array(dtype=wp.int32), item: int, width: int, height: int) -> wp.vec2i:
    """(column, row) of entry ``item`` of a pixel list (flat indices ``row * width +
    column``); (-1, -1) for an entry outside the image, which the kernels skip
    (``listed_pixel_cpp``: the same rule in native code)."""
    pixel = pixels[item]
    if pixel < 0 or pixel >= width * height:
        return wp.vec2i(-1, -1)
    y = pixel // width
    return wp.vec2i(pixel - y * width, y)


def listed_pixel_cpp(entry: str) -> str:
    """C++ statements of ``listed_pixel``'s rule for native code: given ``entry`` (a C++
    expression of a list entry), ``pixels`` (the image's pixel count) and ``width``, they
    define ``inside`` (the entry lies in the image) and its ``x`` and ``y`` (an entry
    outside reads pixel 0, whose values the caller does not use)."""
    return f"""const int listed = {entry};
        const bool inside = listed >= 0 && listed < pixels;
        const int pixel = inside ? listed : 0;
        const int y = pixel / width;
        const int x = pixel - y * width;"""
