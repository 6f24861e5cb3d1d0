"""The budget guard: trace the focus window outward from the gaze until the deadline.

A frame with a ``trace_deadline`` (the budget controller's, a clock reading) traces its
planned window not at once but in rings of equal area, innermost first
(``FocusRegionBuilder.rings``): ``RINGS`` of them, fewer for a window too small to
give each ring ``MIN_RING_PIXELS`` (``ring_count``: a ring costs about a quarter of a
millisecond of launches beyond its pixels, so a small window is not cut into slivers).  Before each ring after the first it reads the clock
(after a device sync) and stops when the ring, at the cost the previous one took,
would end past the deadline: a misprediction of the controller costs at most about
one ring, never the budget.  Where tracing stopped short, the window actually traced
is the nested window up to the last ring done: its weights are rebuilt so the feather
lies where tracing actually stopped, and the compositor shows the raster layer (shaded
everywhere, ``lighting.deferred``) beyond it.  The innermost ring is always traced.
A frame without a deadline is traced in one piece, as the plain ``Tracer`` pass does.
With the mid-resolution ring (``focus.ring``) the ring's lattice pixels (after the
window's in the planned region's list) are one more piece after the window's rings,
estimated at the last ring's cost per pixel: a deadline cuts the ring first, and a frame
that stops before it shows the window with its own feather.  The report counts the
window's rings and pixels (the ring's are in the frame's ``ring`` stats).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.passes import FrameContext, RenderPass
from ..focus import FocusRegionBuilder
from ..scene.device import DeviceScene
from .tracer import Tracer

#: Rings a guarded window is traced in at most (equal areas, so each is 1/RINGS of the window).
#: Each ring is a tracer call with its own launches, so fewer rings leave more of the budget
#: to tracing: 4 instead of 8 traced 14.8-16.3% of the staircase instead of 10.4-11.5% at
#: 320x240 and 15 FPS, with as many frames within the budget.
RINGS = 4
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
        pieces = [(rings.pixels, lo, hi) for lo, hi in zip([0, *rings.ring_ends[:-1]], rings.ring_ends)]
        if planned.ring is not None:  # the mid-resolution ring's lattice pixels follow the window's
            pieces.append((planned.pixels, planned.layout.count, planned.count))
        done = 0
        last_s = 0.0
        last_n = 1
        for pixels, start, end in pieces:
            now = frame.timer.now()
            # The window's rings have equal areas; the mid-resolution ring after them is
            # estimated at the last ring's cost per pixel.
            estimate = last_s if done < count else last_s * (end - start) / last_n
            if done > 0 and now + estimate > frame.trace_deadline:
                break
            if end > start:
                items = pixels[start:end]
                self.tracer.trace(
                    self.scene, frame.camera, gb, items, end - start, b.traced_color, b.visibility, frame.timer
                )
            last_s = frame.timer.now() - now
            last_n = max(end - start, 1)
            done += 1
        frame.rays = tally
        if done < len(pieces):
            frame.region = self.focus.build_layout(rings.layouts[min(done, count) - 1], frame.timer)
        screen = float(gb.width * gb.height)
        self.report = GuardReport(
            min(done, count), count, planned.layout.count / screen, frame.region.layout.count / screen
        )
