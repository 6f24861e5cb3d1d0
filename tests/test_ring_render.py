"""A hybrid frame with the mid-resolution ring: the window is full ray tracing, beyond the
ring raster, and inside the ring the error against full ray tracing drops well below the
raster layer's; the budget guard traces the ring last, and a frame it stops before the ring
is the ring-off frame bit for bit."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from test_modes import H, W, mirror_scene

from warp_hybrid.cli import main
from warp_hybrid.focus import FocusWindow
from warp_hybrid.focus.ring import RingSpec
from warp_hybrid.metrics import layout_mask
from warp_hybrid.renderer import Renderer, RenderSettings


class StepClock:
    """Advances ``step`` seconds per reading (as in tests/trace/test_guard.py)."""

    def __init__(self, step: float = 1.0) -> None:
        self.t = 0.0
        self.step = step

    def __call__(self) -> float:
        self.t += self.step
        return self.t


WINDOW = FocusWindow(gaze=(0.4, 0.5), fraction=0.1, shape="circle", feather_px=4.0)


def _render(scene, mode, device, ring=False, deadline=None, clock=None, window=WINDOW):
    settings = RenderSettings(width=W, height=H, device=device, mode=mode, exposure_ev=0.0, antialias=False, ring=ring)
    kwargs = {"clock": clock} if clock is not None else {}
    with Renderer(scene, settings, **kwargs) as r:
        return r.render(scene.cameras[0], window, trace_deadline=deadline)


def test_inside_the_ring_the_image_is_much_closer_to_full_ray_tracing(device: str) -> None:
    scene = mirror_scene()
    ringed = _render(scene, "hybrid", device, ring=True)
    full = _render(scene, "full", device)
    raster = _render(scene, "raster", device)
    layout = WINDOW.layout(W, H)
    stats = ringed.stats["ring"]
    assert stats["traced"] and stats["scale"] == 2.0 and stats["step"] == 2
    outer = RingSpec().outer(layout)
    assert outer.radius == 2.0 * layout.radius and outer.count < W * H  # inside the screen
    window, within = layout_mask(layout), layout_mask(outer)
    ys, xs = np.mgrid[0:H, 0:W]
    feather_band = 2.0 * layout.radius - np.hypot(xs + 0.5 - layout.cx, ys + 0.5 - layout.cy) < 4.0
    ring = within & ~window & ~feather_band  # weight 1: the upsampled traced layer alone
    assert stats["pixels"] == int((within & ~window & (xs % 2 == 0) & (ys % 2 == 0)).sum())
    np.testing.assert_array_equal(ringed.color[window], full.color[window])
    np.testing.assert_array_equal(ringed.color[~within], raster.color[~within])
    lattice = ring & (xs % 2 == 0) & (ys % 2 == 0)
    np.testing.assert_array_equal(ringed.color[lattice], full.color[lattice])  # traced there
    raster_error = np.abs(raster.color - full.color).mean(axis=-1)
    ring_error = np.abs(ringed.color - full.color).mean(axis=-1)
    assert raster_error[ring].mean() > 0.02  # the ring holds real effects
    assert ring_error[ring].mean() < 0.25 * raster_error[ring].mean()
    # and the whole ring, its feather band included, lies closer than the raster layer
    band = within & ~window
    assert ring_error[band].mean() < 0.5 * raster_error[band].mean()


def test_the_guard_traces_the_ring_last(device: str) -> None:
    scene = mirror_scene()
    plain = _render(scene, "hybrid", device, ring=True)
    unlimited = _render(scene, "hybrid", device, ring=True, deadline=math.inf)
    np.testing.assert_array_equal(unlimited.color, plain.color)
    assert unlimited.stats["rays"] == plain.stats["rays"] and unlimited.stats["ring"]["traced"]
    # A passed deadline: the innermost ring of the window only, as without the ring.
    cut = _render(scene, "hybrid", device, ring=True, deadline=-math.inf)
    cut_off = _render(scene, "hybrid", device, ring=False, deadline=-math.inf)
    assert not cut.stats["ring"]["traced"]
    np.testing.assert_array_equal(cut.color, cut_off.color)
    assert cut.stats["guard"] == cut_off.stats["guard"] and cut.stats["rays"] == cut_off.stats["rays"]


def test_a_deadline_cuts_the_ring_before_the_window(device: str) -> None:
    """With a clock that advances 1 s per reading, the deadline that traces the whole window
    but not the ring gives the ring-off frame of the whole window, bit for bit."""
    scene = mirror_scene()
    window = FocusWindow(gaze=(0.4, 0.5), fraction=0.3, shape="circle", feather_px=4.0)  # several rings
    off = _render(scene, "hybrid", device, window=window)
    clock = StepClock(1.0)
    settings = RenderSettings(width=W, height=H, device=device, exposure_ev=0.0, antialias=False, ring=True)
    with Renderer(scene, settings, clock=clock) as r:
        seen = []
        for slack in range(120):
            frame = r.render(scene.cameras[0], window, trace_deadline=clock.t + slack)
            guard = frame.stats["guard"]
            whole = guard["rings_traced"] == guard["rings"]
            seen.append((guard["rings_traced"], frame.stats["ring"]["traced"]))
            if whole and not frame.stats["ring"]["traced"]:
                np.testing.assert_array_equal(frame.color, off.color)
    assert seen == sorted(seen)
    assert seen[-1][1] and (seen[-1][0], False) in seen  # the window whole without the ring came first


def test_the_command_line_renders_a_ring_on_a_budget(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """``--ring`` reaches the renderer and the controller (``--fps``: the adaptive loop)."""
    scene = str(Path(__file__).resolve().parents[1] / "scenes" / "cornell_glass.usda")
    stats_path = tmp_path / "s.json"
    args = ["render", scene, "-o", str(tmp_path / "r.png"), "--size", "64x48", "--ring", "--ring-scale", "1.5"]
    assert main([*args, "--fps", "15", "--warm-up", "2", "--stats-json", str(stats_path)]) == 0
    stats = json.loads(stats_path.read_text())
    assert stats["ring"]["scale"] == 1.5 and stats["ring"]["step"] == 2
    assert "upsample" in stats["stages_ms"] or not stats["ring"]["traced"]
    assert main([*args, "--ring-step", "1"]) == 2
    assert "ring step" in capsys.readouterr().err
