"""The gaze-centred focus window: its parameters and their layout on a screen.

A ``FocusWindow`` says where the viewer looks and how much of the screen to trace;
``FocusWindow.layout(width, height)`` places it on a ``width x height`` screen.

Size.  ``fraction`` F is the share of the screen AREA to trace.  A circle has radius
``r = sqrt(F * W * H / pi)``; a rect has the screen's aspect ratio, half sizes
``hw = sqrt(F) * W / 2`` and ``hh = sqrt(F) * H / 2``.  F = 0 covers no pixel;
F = 1 covers every pixel whatever the shape (the layout's shape is then ``"full"``).

Clamping at the screen edges.  The gaze is first clamped to [0, 1]^2 and scaled to
pixels.  The window then keeps its size and is shifted so that it lies inside the
screen: the centre is clamped to [r, W - r] x [r, H - r] for a circle and to
[hw, W - hw] x [hh, H - hh] for a rect.  Where the window is larger than the screen
in a dimension (a circle with 2r > W or 2r > H; a rect never is), the centre is the
screen centre in that dimension and the screen edges cut the window: the traced area
is the intersection of the window with the screen.

Pixels.  Pixel (i, j) (column, row) is inside when its centre (i + 0.5, j + 0.5) lies
strictly inside the shape.  Every row's inside pixels are one contiguous run of
columns, evaluated per row in float64 (``WindowLayout.row_spans``); the pixel count,
bounding box and the focus region's pixel list all derive from these runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

SHAPES = ("circle", "rect")

# A rect edge this close to (or beyond) a screen edge lies on the screen edge.
_EDGE_EPS_PX = 1e-6


@dataclass(frozen=True)
class WindowLayout:
    """A focus window placed on a ``width x height`` screen (all lengths in pixels).

    ``shape`` is ``"circle"``, ``"rect"`` or ``"full"`` (fraction >= 1: every pixel).
    ``(cx, cy)`` is the centre after clamping; ``half_width, half_height`` are the
    shape's half extents (both the radius for a circle, W/2 and H/2 for full).
    ``[x0, x1) x [y0, y1)`` is the integer bounding box of the covered pixels (all
    zero when none is covered) and ``count`` the exact number of covered pixels.
    """

    width: int
    height: int
    shape: str
    cx: float
    cy: float
    half_width: float
    half_height: float
    feather_px: float
    x0: int
    x1: int
    y0: int
    y1: int
    count: int
    spans: tuple[np.ndarray, np.ndarray] = field(default=None, compare=False, repr=False)  # type: ignore[assignment]

    @property
    def radius(self) -> float:
        """The circle's radius (only meaningful for ``shape == "circle"``)."""
        return self.half_width

    @property
    def covered_fraction(self) -> float:
        """Covered pixels over screen pixels."""
        return self.count / float(self.width * self.height)

    def scaled(self, scale: float) -> WindowLayout:
        """The same window shrunk about its (clamped) centre: half extents times
        ``scale`` in (0, 1] (area times ``scale**2``).  A full-screen layout shrinks to a
        rect of the screen's aspect.  Nested scales give nested pixel sets, so rings
        between them partition the window (the budget guard traces them outward)."""
        if not 0.0 < scale <= 1.0:
            raise ValueError(f"scale must be in (0, 1], got {scale}")
        if scale == 1.0:
            return self
        shape = "rect" if self.shape == "full" else self.shape
        return placed(
            shape,
            self.width,
            self.height,
            self.cx,
            self.cy,
            self.half_width * scale,
            self.half_height * scale,
            self.feather_px,
        )

    def row_spans(self) -> tuple[np.ndarray, np.ndarray]:
        """Per screen row j, the covered columns ``[start[j], stop[j])`` (int64, length H;
        empty rows have start == stop == 0)."""
        if self.spans is not None:
            return self.spans
        return _row_spans(self.shape, self.width, self.height, self.cx, self.cy, self.half_width, self.half_height)

    @property
    def seam_edges(self) -> tuple[bool, bool, bool, bool]:
        """Rect only: whether its left, top, right and bottom edges are seams to feather,
        i.e. lie inside the screen (a screen edge is not a seam; a rect shifted flush
        against an edge, or covering the whole screen, is not feathered there)."""
        return (
            self.cx - self.half_width > _EDGE_EPS_PX,
            self.cy - self.half_height > _EDGE_EPS_PX,
            self.cx + self.half_width < self.width - _EDGE_EPS_PX,
            self.cy + self.half_height < self.height - _EDGE_EPS_PX,
        )


@dataclass(frozen=True)
class FocusWindow:
    """Where the viewer looks and how much of the screen to trace.

    ``gaze``: normalised (x, y), origin top-left, x right, y down; values outside
    [0, 1] are clamped by ``layout``.  ``fraction``: share of the screen area to trace,
    in [0, 1].  ``shape``: ``"circle"`` or ``"rect"``.  ``feather_px``: width of the
    blend band just inside the window's boundary, >= 0.
    """

    gaze: tuple[float, float]
    fraction: float
    shape: str = "circle"
    feather_px: float = 16.0

    def __post_init__(self) -> None:
        """Validate every field, with a clear message for each bad value."""
        try:
            gx, gy = (float(v) for v in self.gaze)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"focus window gaze must be two numbers (x, y), got {self.gaze!r}") from exc
        if math.isnan(gx) or math.isnan(gy):
            raise ValueError(f"focus window gaze must not be NaN, got ({gx}, {gy})")
        object.__setattr__(self, "gaze", (gx, gy))
        fraction = float(self.fraction)
        if not 0.0 <= fraction <= 1.0:
            raise ValueError(f"focus window fraction must be in [0, 1] (share of the screen area), got {self.fraction}")
        object.__setattr__(self, "fraction", fraction)
        if self.shape not in SHAPES:
            raise ValueError(f"focus window shape must be one of {', '.join(SHAPES)}, got {self.shape!r}")
        feather = float(self.feather_px)
        if not math.isfinite(feather) or feather < 0.0:
            raise ValueError(f"focus window feather must be a finite number of pixels >= 0, got {self.feather_px}")
        object.__setattr__(self, "feather_px", feather)

    def layout(self, width: int, height: int) -> WindowLayout:
        """Place the window on a ``width x height`` screen (clamping rule in the module
        docstring: clamp the gaze to [0, 1]^2, keep the size, shift the window inside
        the screen; centre it in a dimension where it is larger than the screen)."""
        if width <= 0 or height <= 0:
            raise ValueError(f"screen size must be positive, got {width}x{height}")
        w, h = float(width), float(height)
        gx = min(max(self.gaze[0], 0.0), 1.0) * w
        gy = min(max(self.gaze[1], 0.0), 1.0) * h
        if self.fraction >= 1.0:
            shape, cx, cy, hw, hh = "full", w / 2.0, h / 2.0, w / 2.0, h / 2.0
        elif self.shape == "circle":
            shape = "circle"
            hw = hh = math.sqrt(self.fraction * w * h / math.pi)
            cx = _clamp_centre(gx, hw, w)
            cy = _clamp_centre(gy, hh, h)
        else:
            shape = "rect"
            scale = math.sqrt(self.fraction)
            hw, hh = scale * w / 2.0, scale * h / 2.0
            cx = _clamp_centre(gx, hw, w)
            cy = _clamp_centre(gy, hh, h)
        return placed(shape, width, height, cx, cy, hw, hh, self.feather_px)


def placed(
    shape: str, width: int, height: int, cx: float, cy: float, hw: float, hh: float, feather_px: float
) -> WindowLayout:
    """The layout of a placed shape: its covered pixels' bounding box and count."""
    start, stop = _row_spans(shape, width, height, cx, cy, hw, hh)
    lengths = stop - start
    count = int(lengths.sum())
    if count == 0:
        x0 = x1 = y0 = y1 = 0
    else:
        rows = np.flatnonzero(lengths)
        y0, y1 = int(rows[0]), int(rows[-1]) + 1
        x0, x1 = int(start[rows].min()), int(stop[rows].max())
    start.flags.writeable = False
    stop.flags.writeable = False
    return WindowLayout(width, height, shape, cx, cy, hw, hh, feather_px, x0, x1, y0, y1, count, (start, stop))


def _clamp_centre(g: float, half: float, size: float) -> float:
    """Centre coordinate for gaze ``g`` of a window with half extent ``half`` on a screen
    dimension of ``size``: clamped to [half, size - half], or size / 2 if it does not fit."""
    if 2.0 * half > size:
        return size / 2.0
    return min(max(g, half), size - half)


def _row_spans(
    shape: str, width: int, height: int, cx: float, cy: float, hw: float, hh: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per row, the columns whose pixel centres lie strictly inside the shape."""
    dy = np.arange(height, dtype=np.float64) + 0.5 - cy
    if shape == "full":
        return np.zeros(height, dtype=np.int64), np.full(height, width, dtype=np.int64)
    if shape == "circle":
        inside = dy * dy < hw * hw
        half = np.sqrt(np.maximum(hw * hw - dy * dy, 0.0))
    else:
        inside = np.abs(dy) < hh
        half = np.full(height, hw)
    # Column i is inside when cx - half < i + 0.5 < cx + half.
    start = np.clip(np.floor(cx - half - 0.5).astype(np.int64) + 1, 0, width)
    stop = np.clip(np.ceil(cx + half - 0.5).astype(np.int64), 0, width)
    empty = ~inside | (stop <= start)
    start[empty] = 0
    stop[empty] = 0
    return start, stop
