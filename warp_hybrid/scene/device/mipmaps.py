"""Mip chains for material textures (host side).

Level ``L`` of a ``w`` x ``h`` image is ``max(1, w >> L)`` x ``max(1, h >> L)`` texels
(OpenGL's floor convention) and the chain runs down to 1 x 1, so a chain has
``max(w, h).bit_length()`` levels.  Each level is the exact area (box) filter of the
one above it: every new texel is the mean of the block of old texels it covers,
partial texels weighted by the covered fraction, so an even axis averages pairs and
an odd axis of ``n = 2m + 1`` texels maps to ``m`` texels, output ``i`` covering
input texels ``2i .. 2i + 2`` with weights ``(m - i, m, i + 1) / n``.  Because those
blocks nest, every level is also the exact area average of level 0.  (OpenCV's
``INTER_AREA`` resize computes exactly this, 5-10x faster than numpy slicing.)

Normal maps get the same chain: scale and bias are affine, so the box filter of the
stored texels is the box filter of the decoded normals; those averages are shorter
than unit where the normals vary, and the shading renormalises the filtered sample
(``surface.perturb_normal``), which keeps the mean direction.

``DeviceScene`` packs the levels of an image one after the other into the flat texel
array, level 0 first, so kernels find level ``L`` by adding up the sizes of the levels
before it.
"""

from __future__ import annotations

import cv2
import numpy as np


def mip_level_count(width: int, height: int) -> int:
    """Levels of the chain of a ``width`` x ``height`` image, down to 1 x 1."""
    return max(int(width), int(height), 1).bit_length()


def mip_level_size(width: int, height: int, level: int) -> tuple[int, int]:
    """(width, height) of mip ``level`` of a ``width`` x ``height`` image."""
    return max(1, int(width) >> level), max(1, int(height) >> level)


def downsample(pixels: np.ndarray) -> np.ndarray:
    """The next mip level of an (H, W, C) float32 image (row 0 at the top)."""
    a = np.ascontiguousarray(pixels, dtype=np.float32)
    h, w, c = a.shape
    nw, nh = mip_level_size(w, h, 1)
    return cv2.resize(a, (nw, nh), interpolation=cv2.INTER_AREA).reshape(nh, nw, c)


def mip_chain(pixels: np.ndarray) -> list[np.ndarray]:
    """All levels of an (H, W, C) image, level 0 (the image itself) first, down to 1 x 1."""
    levels = [np.ascontiguousarray(pixels, dtype=np.float32)]
    for _ in range(1, mip_level_count(pixels.shape[1], pixels.shape[0])):
        levels.append(downsample(levels[-1]))
    return levels
