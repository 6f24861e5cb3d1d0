"""The focus region: the compacted list of pixels to trace and the blend weights.

The feather band lies inside the window: a pixel's weight is
``smoothstep(0, feather, d)`` with ``d`` its distance to the window's seam (circle:
``r - |p - c|``; rect: the nearest edge that lies inside the screen; screen edges are
not seams), so it is 1 at least ``feather_px`` inside the boundary, falls smoothly
to 0 at the boundary and is 0 outside the window.  Every covered pixel has a weight
> 0 (one whose centre lies inside by less than float precision gets the smallest
normal float32), so the traced pixel list is exactly the set of pixels with weight
> 0, and pixels outside the window keep the raster result exactly.  With
``feather_px == 0`` the weight is a hard 0/1.

Building: the host computes the per-row column runs (``WindowLayout.row_spans``,
O(H)) and their offsets in the list; one kernel launch, one thread per screen row,
writes each row's pixel indices and weights and resets the weights the previous
window covered, so the work is proportional to the window's area (plus O(H)).  The device buffers are allocated once
per resolution and reused, so a region returned by ``build`` is valid until the next
``build`` call.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import warp as wp

from ..core.passes import FrameContext, RenderPass
from ..parallel import Launcher
from ..timing import StageTimer
from .kernels import SHAPE_CIRCLE, SHAPE_FULL, SHAPE_RECT, FocusGPU, focus_rows, list_runs
from .window import FocusWindow, WindowLayout

if TYPE_CHECKING:
    from .ring import RingLayout

_SHAPE_CODES = {"circle": SHAPE_CIRCLE, "rect": SHAPE_RECT, "full": SHAPE_FULL}
_FAR = 1e30  # stand-in coordinate for a rect edge that is not a seam


@dataclass
class FocusRegion:
    """The pixels to trace and how to blend them.

    ``pixels``: int32 flat indices ``row * W + col`` in row-major order; only the first
    ``count`` entries are meaningful (the array may be longer).  ``weight``: (H, W)
    float32 blend weight of the traced layer, > 0 exactly at the listed pixels.
    ``ring``: the mid-resolution ring around the window (``focus.ring``), or None: its
    lattice pixels follow the window's in the list, and its weights are > 0 over the
    whole ring, whose other pixels the upsampler fills (``compose.upsample``).
    """

    pixels: wp.array
    count: int
    weight: wp.array
    layout: WindowLayout
    ring: RingLayout | None = None

    @property
    def _covered(self) -> WindowLayout:
        """The layout whose box holds every pixel with ``weight`` > 0."""
        return self.layout if self.ring is None else self.ring.outer

    @property
    def rows(self) -> tuple[int, int]:
        """(first, stop): the only rows where ``weight`` may be > 0."""
        return self._covered.y0, self._covered.y1

    @property
    def cols(self) -> tuple[int, int]:
        """(first, stop): the only columns where ``weight`` may be > 0."""
        return self._covered.x0, self._covered.x1


@dataclass
class RingedRegion:
    """A planned window's pixels in rings ordered outward from its centre, for tracing
    under a deadline: ring k is ``pixels[ring_ends[k - 1]:ring_ends[k]]`` and the window
    up to ring k is ``layouts[k]`` (the last one the planned window itself)."""

    pixels: wp.array
    ring_ends: list[int]
    layouts: list[WindowLayout]


#: The fewest runs a band of ``list_runs`` holds on the CPU: a run writes a few hundred
#: indices, a launch costs tens of us, so a window's runs go out in one band per thread.
RUN_BAND_ITEMS = 1 << 14


def ring_runs(layouts: list[WindowLayout]) -> tuple[np.ndarray, list[int]]:
    """The column runs of each ring between nested ``layouts`` (innermost first): per
    ring and row up to two runs, outer span minus inner span, as (4, 2 * rings * H)
    int32 rows (row, start, stop, offset in the ring-ordered list), and the list's
    cumulative length after each ring."""
    height = layouts[0].height
    rows = np.arange(height, dtype=np.int64)
    inner_a = np.zeros(height, dtype=np.int64)
    inner_b = np.zeros(height, dtype=np.int64)
    pieces = []
    for layout in layouts:
        a, b = layout.row_spans()
        hollow = inner_b > inner_a  # the inner window covers part of this row
        left_stop = np.where(hollow, inner_a, b)
        right_start = np.where(hollow, inner_b, b)
        pieces.append(np.stack([rows, a, left_stop]))
        pieces.append(np.stack([rows, right_start, b]))
        inner_a, inner_b = a, b
    runs = np.concatenate(pieces, axis=1)
    lengths = runs[2] - runs[1]
    offsets = np.cumsum(lengths) - lengths
    ring_ends = [int(v) for v in np.cumsum(lengths.reshape(len(layouts), -1).sum(axis=1))]
    return np.ascontiguousarray(np.vstack([runs, offsets]).astype(np.int32)), ring_ends


def focus_params(layout: WindowLayout) -> FocusGPU:
    """The kernel's view of a layout."""
    p = FocusGPU()
    p.width = layout.width
    p.shape = _SHAPE_CODES[layout.shape]
    p.cx, p.cy, p.radius = layout.cx, layout.cy, layout.radius
    seam_left, seam_top, seam_right, seam_bottom = layout.seam_edges if layout.shape == "rect" else (False,) * 4
    p.left = layout.cx - layout.half_width if seam_left else -_FAR
    p.top = layout.cy - layout.half_height if seam_top else -_FAR
    p.right = layout.cx + layout.half_width if seam_right else _FAR
    p.bottom = layout.cy + layout.half_height if seam_bottom else _FAR
    p.hard = int(layout.feather_px == 0.0)
    p.inv_feather = 0.0 if p.hard else 1.0 / layout.feather_px
    return p


class FocusRegionBuilder(RenderPass):
    """Builds ``FocusRegion``s for one screen size, reusing its device buffers (the
    "focus" pass: the frame's window, or every pixel when the frame has none)."""

    def __init__(self, launcher: Launcher, width: int, height: int) -> None:
        """Allocate the buffers for ``width`` x ``height`` on the launcher's device."""
        self.launcher = launcher
        self.resize(width, height)

    def execute(self, frame: FrameContext) -> None:
        """Set ``frame.region``: the frame's window, or the full screen without one."""
        frame.region = self.full_screen() if frame.window is None else self.build(frame.window, frame.timer)

    def resize(self, width: int, height: int) -> None:
        """Allocate the pixel list (W*H int32), weight (H, W) and row-run buffers."""
        if width <= 0 or height <= 0:
            raise ValueError(f"screen size must be positive, got {width}x{height}")
        self.width = width
        self.height = height
        device = self.launcher.device
        self._pixels = wp.empty(width * height, dtype=wp.int32, device=device)
        self._weight = wp.zeros((height, width), dtype=wp.float32, device=device)
        # Rows 0-2: first covered column, end column, offset of the row's run in the list;
        # rows 3-4: the run of the weight buffer's previous fill (to reset to 0).
        self._spans = wp.zeros((5, height), dtype=wp.int32, device=device)
        if device.is_cpu:
            self._spans_stage, self._uploaded = self._spans, None
        else:
            self._spans_stage = wp.zeros((5, height), dtype=wp.int32, device="cpu", pinned=True)
            self._uploaded = wp.Event(device)
        self._spans_host = self._spans_stage.numpy()
        self._previous = np.zeros((2, height), dtype=np.int64)
        self._full: FocusRegion | None = None
        self._runs: wp.array | None = None
        self._ring_pixels: wp.array | None = None

    def build(self, window: FocusWindow, timer: StageTimer) -> FocusRegion:
        """Lay ``window`` out on this screen and fill the pixel list and weights
        (stage ``"focus"``).  The result shares buffers with the next ``build``."""
        return self.build_layout(window.layout(self.width, self.height), timer)

    def build_layout(self, layout: WindowLayout, timer: StageTimer) -> FocusRegion:
        """``build`` for a window already placed on this screen."""
        with timer.stage("focus"):
            self._fill(layout, self._pixels, self._weight, self._previous)
            return FocusRegion(self._pixels, layout.count, self._weight, layout)

    def rings(self, layout: WindowLayout, count: int, timer: StageTimer) -> RingedRegion:
        """``layout``'s pixels in ``count`` rings of equal area ordered outward (stage
        ``"focus"``), in buffers of their own reused by the next call."""
        with timer.stage("focus"):
            layouts = [layout.scaled(((k + 1) / count) ** 0.5) for k in range(count)]
            runs, ends = ring_runs(layouts)
            runs = np.ascontiguousarray(runs[:, runs[2] > runs[1]])  # the empty runs list nothing
            device = self.launcher.device
            if self._runs is None or self._runs.shape != runs.shape:
                self._runs = wp.empty(runs.shape, dtype=wp.int32, device=device)
                self._ring_pixels = wp.empty(self.width * self.height, dtype=wp.int32, device=device)
            self._runs.assign(runs)
            self.launcher.launch_items(
                list_runs, runs.shape[1], [self._runs, self.width, self._ring_pixels], min_band_items=RUN_BAND_ITEMS
            )
            return RingedRegion(self._ring_pixels, ends, layouts)

    def full_screen(self) -> FocusRegion:
        """A region of every pixel with weight 1 (``--mode full``); built once, in its own buffers."""
        if self._full is None:
            device = self.launcher.device
            layout = FocusWindow(gaze=(0.5, 0.5), fraction=1.0).layout(self.width, self.height)
            pixels = wp.empty(self.width * self.height, dtype=wp.int32, device=device)
            weight = wp.zeros((self.height, self.width), dtype=wp.float32, device=device)
            self._fill(layout, pixels, weight, np.zeros((2, self.height), dtype=np.int64))
            self._full = FocusRegion(pixels, layout.count, weight, layout)
        return self._full

    def _fill(self, layout: WindowLayout, pixels: wp.array, weight: wp.array, previous: np.ndarray) -> None:
        """Upload the layout's row runs and launch the per-row kernel; ``previous`` (2, H)
        holds the runs of ``weight``'s last fill and is updated to this one's."""
        if self._uploaded is not None:
            wp.synchronize_event(self._uploaded)  # the previous upload has left the staging buffer
        start, stop = layout.row_spans()
        lengths = stop - start
        self._spans_host[0] = start
        self._spans_host[1] = stop
        self._spans_host[2] = np.cumsum(lengths) - lengths
        self._spans_host[3:5] = previous
        previous[0] = start
        previous[1] = stop
        if self._uploaded is not None:
            stream = self.launcher.device.stream
            wp.copy(self._spans, self._spans_stage, stream=stream)
            stream.record_event(self._uploaded)
        self.launcher.launch_items(focus_rows, self.height, [focus_params(layout), self._spans, pixels, weight])
