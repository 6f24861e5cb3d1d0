"""The focus pass with the mid-resolution ring (``focus.ring``): the window's pixels, then
the ring's lattice pixels, in one list; the outer shape's blend weights (one Warp module,
compiled only with ``--ring``)."""

from __future__ import annotations

import numpy as np
import warp as wp

from ..core.passes import FrameContext
from ..parallel import Launcher
from ..timing import StageTimer
from .region import FocusRegion, FocusRegionBuilder
from .ring import RingLayout, RingSpec, lattice_runs
from .window import FocusWindow

wp.set_module_options({"enable_backward": False})


@wp.kernel
def list_strided_runs(
    runs: wp.array2d(dtype=wp.int32), width: int, pixels: wp.array(dtype=wp.int32), start: int, step: int
):
    """Run ``i``: row ``runs[0, i]``, columns ``runs[1, i]``, ``+ runs[4, i]``, ... below
    ``runs[2, i]`` -> their flat indices at ``pixels[runs[3, i]:]``."""
    i = start + wp.tid() * step
    row = runs[0, i]
    stride = runs[4, i]
    k = runs[3, i]
    for x in range(runs[1, i], runs[2, i], stride):
        pixels[k] = row * width + x
        k += 1


class RingedFocusBuilder(FocusRegionBuilder):
    """The focus pass with the mid-resolution ring (module docstring): a frame's window
    plus its ring; a full-screen frame has none."""

    def __init__(self, launcher: Launcher, width: int, height: int, ring: RingSpec) -> None:
        """Allocate the buffers for ``width`` x ``height``; ``ring`` sizes every window's ring."""
        ring.validate()
        self.ring = ring
        super().__init__(launcher, width, height)
        launcher.ensure_loaded(list_strided_runs)

    def resize(self, width: int, height: int) -> None:
        """The plain builder's buffers, and the ring's spans (4, H) and runs (the guard
        traces the ring from the region's own list: ``trace.guard``)."""
        super().resize(width, height)
        self._ring_spans = wp.zeros((4, height), dtype=wp.int32, device=self.launcher.device)
        self._lattice: wp.array | None = None

    def execute(self, frame: FrameContext) -> None:
        """Set ``frame.region``: the frame's window and its ring, or the full screen."""
        frame.region = self.full_screen() if frame.window is None else self.build_ringed(frame.window, frame.timer)

    def build_ringed(self, window: FocusWindow, timer: StageTimer) -> FocusRegion:
        """Lay ``window`` (a ``FocusWindow``) and its ring out and fill the pixel list
        (window, then ring) and the weights (the outer shape's) (stage ``"focus"``).
        Shares buffers with the next build; a window without a ring gets ``build``'s
        region."""
        layout = window.layout(self.width, self.height)
        outer = self.ring.outer(layout)
        if outer is None:
            return self.build_layout(layout, timer)
        with timer.stage("focus"):
            self._fill(outer, self._pixels, self._weight, self._previous)  # the weights (and a list overwritten next)
            runs, total = lattice_runs(layout, outer, self.ring.step)
            device = self.launcher.device
            if self._lattice is None or self._lattice.shape != runs.shape:
                self._lattice = wp.empty(runs.shape, dtype=wp.int32, device=device)
            self._lattice.assign(runs)
            self.launcher.launch_items(list_strided_runs, runs.shape[1], [self._lattice, self.width, self._pixels])
            spans = np.vstack([*outer.row_spans(), *layout.row_spans()]).astype(np.int32)
            self._ring_spans.assign(spans)
            ring = RingLayout(outer, self.ring.step, total - layout.count, self._ring_spans)
            return FocusRegion(self._pixels, total, self._weight, layout, ring)
