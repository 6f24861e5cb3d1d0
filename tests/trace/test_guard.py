"""The budget guard: a window traced outward in rings under a deadline stops where the
clock says, and the image is exactly full-mode inside what was traced, raster-mode
outside it, with the feather where tracing stopped."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_modes import H, W, mirror_scene

from warp_hybrid.focus import FocusWindow
from warp_hybrid.renderer import Renderer, RenderSettings
from warp_hybrid.trace.guard import MIN_RING_PIXELS, RINGS, ring_count


class StepClock:
    """Advances ``step`` seconds per reading: the guard's clock readings are countable."""

    def __init__(self, step: float = 1.0) -> None:
        self.t = 0.0
        self.step = step

    def __call__(self) -> float:
        self.t += self.step
        return self.t


def _render(scene, mode, device, window=None, deadline=None, clock=None):
    settings = RenderSettings(width=W, height=H, device=device, mode=mode, exposure_ev=0.0, antialias=False)
    kwargs = {"clock": clock} if clock is not None else {}
    with Renderer(scene, settings, **kwargs) as r:
        return r.render(scene.cameras[0], window, trace_deadline=deadline)


WINDOW = FocusWindow(gaze=(0.4, 0.5), fraction=0.3, shape="circle", feather_px=4.0)
WINDOW_RINGS = ring_count(WINDOW.layout(W, H).count)


def test_a_small_window_is_traced_in_fewer_rings() -> None:
    assert ring_count(RINGS * MIN_RING_PIXELS) == RINGS
    assert ring_count(10**9) == RINGS
    assert ring_count(3 * MIN_RING_PIXELS + 1) == 3
    assert ring_count(MIN_RING_PIXELS - 1) == ring_count(0) == 1
    assert WINDOW_RINGS >= 4  # the tests below cut this window into several rings


def test_a_deadline_that_is_never_reached_traces_the_whole_window_exactly(device: str) -> None:
    scene = mirror_scene()
    plain = _render(scene, "hybrid", device, WINDOW)
    guarded = _render(scene, "hybrid", device, WINDOW, deadline=math.inf)
    np.testing.assert_array_equal(guarded.color, plain.color)
    np.testing.assert_array_equal(guarded.visibility, plain.visibility)
    assert guarded.stats["guard"] == {
        "rings_traced": WINDOW_RINGS,
        "rings": WINDOW_RINGS,
        "planned_fraction": pytest.approx(plain.stats["window"]["covered_fraction"]),
        "traced_fraction": pytest.approx(plain.stats["window"]["covered_fraction"]),
    }
    assert guarded.stats["rays"] == plain.stats["rays"]


def test_a_passed_deadline_traces_the_innermost_ring_and_feathers_there(device: str) -> None:
    scene = mirror_scene()
    frame = _render(scene, "hybrid", device, WINDOW, deadline=-math.inf)
    full = _render(scene, "full", device)
    raster = _render(scene, "raster", device)
    guard = frame.stats["guard"]
    assert guard["rings_traced"] == 1
    assert guard["traced_fraction"] == pytest.approx(guard["planned_fraction"] / WINDOW_RINGS, rel=0.05)
    assert frame.stats["rays"]["traced_pixels"] == frame.stats["window"]["pixels"]
    layout = WINDOW.layout(W, H)
    radius = layout.radius / math.sqrt(WINDOW_RINGS)  # the innermost ring's outer edge
    ys, xs = np.mgrid[0:H, 0:W]
    dist = radius - np.hypot(xs + 0.5 - layout.cx, ys + 0.5 - layout.cy)
    inner = dist > 4.0 + 1e-3
    outside = dist < -1e-3
    assert inner.sum() > 20 and outside.sum() > 5000
    np.testing.assert_array_equal(frame.color[inner], full.color[inner])
    # outside the traced ring the raster layer shows (it is shaded everywhere)
    np.testing.assert_array_equal(frame.color[outside], raster.color[outside])
    assert np.isnan(frame.visibility[outside]).all()


def test_the_guard_stops_where_the_clock_says(device: str) -> None:
    """With a clock that advances 1 s per reading, later deadlines trace more rings, one
    more at a time, from the innermost ring alone to the whole window."""
    scene = mirror_scene()
    clock = StepClock(1.0)
    settings = RenderSettings(width=W, height=H, device=device, mode="hybrid", exposure_ev=0.0, antialias=False)
    with Renderer(scene, settings, clock=clock) as r:
        counts = []
        for slack in range(0, 90):
            frame = r.render(scene.cameras[0], WINDOW, trace_deadline=clock.t + slack)
            counts.append(frame.stats["guard"]["rings_traced"])
    assert counts == sorted(counts)
    assert set(counts) == set(range(1, WINDOW_RINGS + 1))
