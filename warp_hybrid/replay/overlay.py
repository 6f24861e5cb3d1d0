"""The focus window and the gaze point drawn over a frame (OpenCV), for the replay video.

Coordinates are continuous pixel coordinates (README conventions): pixel (i, j) is
column i, row j, its centre at (i + 0.5, j + 0.5), row 0 at the top.  Outlines are 1 px
(8-connected) and land on the pixels nearest the true shape: OpenCV draws with 8
fractional bits (``shift``), so a centre or radius between pixels is not rounded to
whole pixels first.  The gaze cross is centred on the pixel that holds the gaze point.

Colours (RGB): ``WINDOW_COLOUR`` for the planned focus window, ``TRACED_COLOUR`` for
where tracing stopped when it stopped short of it, ``GAZE_COLOUR`` for the gaze cross.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

WINDOW_COLOUR = (255, 255, 0)  # yellow
TRACED_COLOUR = (0, 255, 255)  # cyan
GAZE_COLOUR = (255, 0, 255)  # magenta

#: Length of the gaze cross's arms in pixels either side of its centre pixel.
GAZE_ARM_PX = 4

_SHIFT = 8  # fractional bits of the coordinates handed to OpenCV
_ONE = 1 << _SHIFT
_SHAPES = ("circle", "rect", "full")


def _fixed(x: float, y: float) -> tuple[int, int]:
    """A continuous pixel position as OpenCV's fixed point (its integer (i, j) is pixel
    (i, j)'s centre, hence the -0.5)."""
    return round((x - 0.5) * _ONE), round((y - 0.5) * _ONE)


def _outline(
    image: np.ndarray,
    centre: tuple[float, float],
    shape: str,
    half_width: float,
    half_height: float,
    colour: tuple[int, int, int],
) -> None:
    """Draw a circle of radius ``half_width`` or a rect of these half extents, in place."""
    cx, cy = centre
    if shape == "circle":
        cv2.circle(image, _fixed(cx, cy), round(half_width * _ONE), colour, 1, cv2.LINE_8, _SHIFT)
    else:
        top_left = _fixed(cx - half_width, cy - half_height)
        bottom_right = _fixed(cx + half_width, cy + half_height)
        cv2.rectangle(image, top_left, bottom_right, colour, 1, cv2.LINE_8, _SHIFT)


def draw_overlay(
    image: np.ndarray,
    centre_px: tuple[float, float],
    shape: str,
    half_width: float,
    half_height: float,
    gaze_px: tuple[float, float] | None,
    traced_radius_px: float | None = None,
) -> np.ndarray:
    """A copy of the (H, W, 3) uint8 RGB ``image`` with the focus window and gaze drawn.

    ``centre_px``, ``shape``, ``half_width``, ``half_height``: the placed window
    (``WindowLayout.cx, cy, shape, half_width, half_height``); a circle's radius is
    ``half_width``, ``"full"`` is drawn as a rect.  ``gaze_px``: the gaze point in
    pixels (``None``: no cross).  ``traced_radius_px``: how far tracing got when it
    stopped short of the window (a circle's radius; a rect's half width, its half height
    scaled alike, as ``WindowLayout.scaled``); drawn in ``TRACED_COLOUR`` when smaller
    than the window, ignored otherwise.
    """
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"expected an (H, W, 3) uint8 image, got {image.shape} {image.dtype}")
    if shape not in _SHAPES:
        raise ValueError(f"window shape must be one of {', '.join(_SHAPES)}, got {shape!r}")
    values = (*centre_px, half_width, half_height)
    if not all(math.isfinite(float(v)) for v in values) or half_width < 0 or half_height < 0:
        raise ValueError(f"window centre and half sizes must be finite and >= 0, got {values}")
    if gaze_px is not None and not all(math.isfinite(float(v)) for v in gaze_px):
        raise ValueError(f"gaze point must be finite, got {gaze_px}")
    out = np.array(image, order="C", copy=True)
    centre = (float(centre_px[0]), float(centre_px[1]))
    _outline(out, centre, shape, half_width, half_height, WINDOW_COLOUR)
    if traced_radius_px is not None and 0.0 <= traced_radius_px < half_width:
        scale = traced_radius_px / half_width
        _outline(out, centre, shape, traced_radius_px, half_height * scale, TRACED_COLOUR)
    if gaze_px is not None:
        pixel = (math.floor(gaze_px[0]), math.floor(gaze_px[1]))
        cv2.drawMarker(out, pixel, GAZE_COLOUR, cv2.MARKER_CROSS, 2 * GAZE_ARM_PX + 1, 1, cv2.LINE_8)
    return out
