"""The budget guard: trace the focus window outward from the gaze until the deadline.

A frame with a ``trace_deadline`` (the budget controller's, a clock reading) traces its
planned window in rings of equal area, innermost first (``FocusRegionBuilder.rings``):
``RINGS`` of them, fewer for a window too small to give each ring ``MIN_RING_PIXELS``
(``ring_count``).  The rings go to the tracer as one list in ring order
(``Tracer.trace_rings``), cut into bands the threads share: the innermost ring is always
traced, and a band of a later ring starts only while the clock (read after a device
sync) says it ends by the deadline at the cost per pixel the frame's bands took so far,
so a misprediction of the controller costs at most about one band, never the budget.
Where tracing stopped short, the window actually traced is the nested window up to the
last ring traced whole: its weights are rebuilt so the feather lies where tracing
stopped, and the compositor shows the raster layer (shaded everywhere,
``lighting.deferred``) beyond it (the pixels of a ring cut short were traced, and are
counted in the ray tally, but are not shown).  A frame without a deadline is traced in
one piece, as the plain ``Tracer`` pass does.  With the mid-resolution ring
(``focus.ring``) the ring's lattice pixels follow the window's rings as one more ring
in the list: a deadline cuts the ring first, and a frame that stops before it shows the
window with its own feather.  The report counts the window's rings and pixels (the
ring's are in the frame's ``ring`` stats).
"""

from __future__ import annotations

from dataclasses import dataclass

import warp as wp

from ..core.passes import FrameContext, RenderPass
from ..focus import FocusRegionBuilder
from ..scene.device import DeviceScene
from .tracer import Tracer

#: Rings a guarded window is traced in at most (equal areas, so each is 1/RINGS of the
#: window): the window shown when the deadline cuts tracing short is the last ring traced
#: whole, so more rings waste less of what was traced; the rings share one tracer call,
#: so a ring costs no launches of its own.
RINGS = 8
#: The fewest pixels a ring holds (below RINGS * MIN_RING_PIXELS, fewer rings).
MIN_RING_PIXELS = 512


def ring_count(pixels: int) -> int:
    """Rings a window of ``pixels`` is traced in: ``RINGS``, or fewer so that each holds
    at least ``MIN_RING_PIXELS`` (one at least)."""
    return max(1, min(RINGS, pixels // MIN_RING_PIXELS))


@dataclass
class GuardReport:
    """How a guarded frame's tracing went: rings traced of ``rings``, the planned and
    the traced window's share of the screen, and whether the deadline cut it short."""

    rings_traced: int
    rings: int
    planned_fraction: float
    traced_fraction: float


class GuardedTrace(RenderPass):
    """The tracing pass of a hybrid frame, with the budget guard (module docstring)."""

    def __init__(self, tracer: Tracer, focus: FocusRegionBuilder) -> None:
        """Guard ``tracer``'s work, with ``focus`` for the rings and the traced window's
        weights."""
        self.tracer = tracer
        self.focus = focus
        self.report: GuardReport | None = None

    def set_scene(self, scene: DeviceScene) -> None:
        """Draw ``scene`` (the wrapped tracer follows)."""
        super().set_scene(scene)
        self.tracer.set_scene(scene)

    def execute(self, frame: FrameContext) -> None:
        """Trace ``frame.region`` (the planned window), under ``frame.trace_deadline`` when
        set; ``frame.region`` becomes the window actually traced."""
        if frame.trace_deadline is None:
            self.tracer.execute(frame)
            self.report = None
            return
        assert self.scene is not None and frame.region is not None, "set_scene and a focus region first"
        b = frame.buffers
        gb = b.gbuffer
        planned = frame.region
        tally = self.tracer.begin_frame(gb.width, gb.height)
        b.visibility.fill_(float("nan"))
        count = ring_count(planned.layout.count)
        rings = self.focus.rings(planned.layout, count, frame.timer)
        ends = list(rings.ring_ends)
        if planned.ring is not None:  # the mid-resolution ring's lattice pixels follow the window's
            lattice = planned.count - planned.layout.count
            if lattice > 0:
                wp.copy(
                    rings.pixels, planned.pixels, dest_offset=ends[-1], src_offset=planned.layout.count, count=lattice
                )
            ends.append(ends[-1] + lattice)
        done = self.tracer.trace_rings(
            self.scene,
            frame.camera,
            gb,
            rings.pixels,
            ends,
            b.traced_color,
            b.visibility,
            frame.timer,
            deadline=frame.trace_deadline,
            reuse_shadows=frame.raster_cached and self.tracer.settings.keep_shadows,
        )
        frame.rays = tally
        if done < len(ends):
            frame.region = self.focus.build_layout(rings.layouts[min(done, count) - 1], frame.timer)
        screen = float(gb.width * gb.height)
        self.report = GuardReport(
            min(done, count), count, planned.layout.count / screen, frame.region.layout.count / screen
        )
