"""The paper's three columns through the renderer: hybrid equals full inside the focus
window and raster outside it; traced work scales with the window's area."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.focus import FocusWindow
from warp_hybrid.renderer import Renderer, RenderSettings
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Light, LightKind, Material

W, H = 96, 72


def mirror_scene():
    """A mirror sphere and a diffuse sphere on a floor under a sun: shadows and reflections."""
    mats = [
        Material("mirror", diffuse=(0.9, 0.9, 0.9), metallic=1.0, roughness=0.0),
        Material("red", diffuse=(0.7, 0.1, 0.1), roughness=0.8),
        Material("floor", diffuse=(0.5, 0.5, 0.5), roughness=0.9),
    ]
    meshes = [
        uv_sphere((-0.8, 0.0, 0.0), 0.7, 24, 48, 0, "/mirror"),
        uv_sphere((0.9, -0.3, 0.3), 0.4, 16, 32, 1, "/red"),
        quad((-5, -0.7, 5), (10, 0, 0), (0, 0, -10), 2, "/floor"),
    ]
    sun = Light(LightKind.DISTANT, "/sun", (3.0, 3.0, 3.0), direction=(-0.4, -1.0, -0.3))
    cam = look_at_camera((0.0, 1.0, 4.5), (0.0, -0.2, 0.0), hfov_deg=55.0)
    return make_scene(meshes, mats, [sun], [cam])


def render(scene, mode: str, window: FocusWindow | None = None, device: str = "cpu"):
    settings = RenderSettings(width=W, height=H, device=device, mode=mode, exposure_ev=0.0, antialias=False)
    with Renderer(scene, settings) as r:
        return r.render(scene.cameras[0], window)


def test_hybrid_is_full_inside_and_raster_outside(device: str) -> None:
    scene = mirror_scene()
    window = FocusWindow(gaze=(0.35, 0.5), fraction=0.2, shape="circle", feather_px=6.0)
    hybrid = render(scene, "hybrid", window, device)
    full = render(scene, "full", None, device)
    raster = render(scene, "raster", None, device)
    layout = window.layout(W, H)
    ys, xs = np.mgrid[0:H, 0:W]
    dist = layout.radius - np.hypot(xs + 0.5 - layout.cx, ys + 0.5 - layout.cy)
    inner = dist > 6.0 + 1e-3
    outside = dist < 0.0
    assert inner.sum() > 300 and outside.sum() > 3000
    np.testing.assert_array_equal(hybrid.color[inner], full.color[inner])
    np.testing.assert_array_equal(hybrid.color[outside], raster.color[outside])
    # the window holds real tracing effects: full differs from raster there
    assert np.abs(full.color[inner] - raster.color[inner]).max() > 0.05
    # visibility: traced inside the window on hit pixels, NaN outside
    vis = hybrid.visibility[..., 0]
    assert np.isnan(vis[outside]).all()
    hit_inner = inner & np.isfinite(hybrid.aovs()["depth"])
    assert np.isfinite(vis[hit_inner]).all() and (vis[hit_inner] >= 0).all() and (vis[hit_inner] <= 1).all()
    assert (vis[hit_inner] == 0).any() and (vis[hit_inner] == 1).any()  # shadowed and lit pixels


@pytest.mark.parametrize("shape", ["circle", "rect"])
def test_traced_pixels_and_rays_scale_with_window_area(device: str, shape: str) -> None:
    scene = mirror_scene()
    stats = {}
    for f in (0.1, 0.4):
        frame = render(scene, "hybrid", FocusWindow(gaze=(0.5, 0.5), fraction=f, shape=shape, feather_px=4.0), device)
        stats[f] = frame.stats
    small, big = stats[0.1], stats[0.4]
    assert big["window"]["pixels"] / small["window"]["pixels"] == pytest.approx(4.0, rel=0.05)
    assert big["rays"]["traced_pixels"] == big["window"]["pixels"]
    assert big["rays"]["shadow"] / small["rays"]["shadow"] == pytest.approx(4.0, rel=0.35)


def test_raster_mode_traces_nothing(device: str) -> None:
    frame = render(mirror_scene(), "raster", None, device)
    assert "rays" not in frame.stats
    assert np.isnan(frame.visibility).all()
    assert not {"trace_shadow", "trace_secondary", "compose"} & set(frame.stats["stages_ms"])


def test_one_exposure_whatever_the_window(device: str) -> None:
    """Automatic exposure is metered on the raster layer (shaded everywhere), so a hybrid
    frame's exposure is raster mode's, wherever the window is and however big: moving
    the gaze over a still scene never changes it."""
    scene = mirror_scene()

    def ev(mode: str, window: FocusWindow | None = None) -> float:
        settings = RenderSettings(width=W, height=H, device=device, mode=mode, antialias=False)
        with Renderer(scene, settings) as r:
            return r.render(scene.cameras[0], window).stats["exposure_ev"]

    raster = ev("raster")
    windows = [FocusWindow(gaze=g, fraction=f) for g, f in (((0.25, 0.5), 0.2), ((0.7, 0.3), 0.2), ((0.5, 0.5), 0.6))]
    assert [ev("hybrid", w) for w in windows] == [raster] * 3
    assert ev("full") != raster  # full ray tracing meters its own (shadowed) image
