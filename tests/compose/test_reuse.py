"""Temporal reuse (``--reuse``): the last frames' traced layer, reprojected through the
G-buffer into pixels that just left the window, fading over ``FADE_FRAMES`` frames,
rejected where the surface is not the one traced."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from warp_hybrid import Renderer, RenderSettings
from warp_hybrid.compose.reuse import FADE_FRAMES, TemporalReuse
from warp_hybrid.focus import FocusWindow
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Camera, Light, LightKind, Material

W, H = 64, 48
HEIGHT = 10.0  # the camera's height over the floor: every floor pixel has view depth 10
FOOTPRINT = 2.0 * HEIGHT * np.tan(np.radians(30.0)) / W  # a pixel's width on the floor


def _box_meshes(x: float) -> list:
    """The floor (material 0) and a unit box standing on it at (x, 0.5, 0) (material 1)."""
    floor = quad((-10.0, 0.0, 10.0), (20.0, 0.0, 0.0), (0.0, 0.0, -20.0), 0)
    h = 0.5
    faces = [
        quad((x - h, 1.0, h), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0), 1),  # top
        quad((x - h, 0.0, h), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 1),  # front
        quad((x + h, 0.0, -h), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 1),  # back
        quad((x - h, 0.0, -h), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0), 1),  # left
        quad((x + h, 0.0, h), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 1),  # right
    ]
    return [floor, *faces]


def _camera(shift_px: float = 0.0) -> Camera:
    """Looking straight down from HEIGHT (image up = -Z), moved ``shift_px`` floor pixels
    along +X (the floor's image moves left by as many whole pixels)."""
    x = shift_px * FOOTPRINT
    return look_at_camera((x, HEIGHT, 0.0), (x, 0.0, 0.0), up=(0.0, 0.0, -1.0), hfov_deg=60.0)


def _scene(box_x: float = -2.0):
    """A matte floor and box (no specular: the traced layer is view-independent) under a
    slanted sun, no dome: the raster layer has no shadow, the traced one has."""
    matte = dict(specular=(0.0, 0.0, 0.0), use_specular_workflow=True, roughness=1.0)
    mats = [Material("/floor", diffuse=(0.8, 0.8, 0.8), **matte), Material("/box", diffuse=(0.3, 0.5, 0.7), **matte)]
    sun = Light(LightKind.DISTANT, "/sun", (3.0, 3.0, 3.0), direction=(0.8, -1.0, 0.1))
    return make_scene(_box_meshes(box_x), mats, lights=[sun], cameras=[_camera()])


def _settings(**kw) -> RenderSettings:
    base = dict(width=W, height=H, mode="hybrid", antialias=False, exposure_ev=0.0, feather_px=0.0, threads=1)
    base.update(kw)
    return RenderSettings(**base)


def _window(gx: float) -> FocusWindow:
    return FocusWindow(gaze=(gx, 0.5), fraction=0.3, shape="circle", feather_px=0.0)


def _inside(gx: float, margin: float = -1.0) -> np.ndarray:
    """(H, W) pixels whose centres lie inside ``_window(gx)`` (a circle of 0.3 of the
    screen) grown by ``margin`` pixels (shrunk by default: surely inside)."""
    radius = np.sqrt(0.3 * W * H / np.pi)
    x, y = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    return np.hypot(x - gx * W, y - 0.5 * H) < radius + margin


def _full(scene, camera: Camera) -> np.ndarray:
    with Renderer(scene, _settings(mode="full")) as r:
        return r.render(camera).color


def test_a_camera_pan_reuses_the_traced_layer_where_the_window_left(device: str) -> None:
    """Frame 1 traces a window on the left; the camera pans 3 floor pixels and frame 2's
    window is on the right.  Every floor pixel of frame 2 outside its window that frame 1
    traced shows frame 1's trace: the full-mode image of frame 2 (shadows included), not
    the unshadowed raster layer plain hybrid shows there."""
    scene = _scene()
    cam2 = _camera(3.0)
    with Renderer(scene, _settings(device=device, reuse=True)) as r:
        r.render(scene.cameras[0], _window(0.3))
        frame = r.render(cam2, _window(0.85))
        reused, tri = frame.color, frame.gbuffer.triangle_id.numpy()
    with Renderer(scene, _settings(device=device)) as r:
        plain = r.render(cam2, _window(0.85)).color
    full = _full(scene, cam2)
    traced_before = np.zeros((H, W), bool)
    traced_before[:, : W - 3] = _inside(0.3)[:, 3:]  # frame 2 pixel x saw frame 1 pixel x + 3
    floor = tri >= 0
    floor &= tri < 2
    check = traced_before & ~_inside(0.85) & floor
    shadowed = check & (full.sum(axis=-1) < 0.5 * plain.sum(axis=-1))
    assert check.sum() > 200 and shadowed.sum() > 10
    np.testing.assert_allclose(reused[check], full[check], rtol=1e-4, atol=1e-5)
    assert np.abs(plain[shadowed] - full[shadowed]).min() > 0.1
    ever = np.zeros((H, W), bool)
    ever[:, : W - 3] = _inside(0.3, 1.0)[:, 3:]
    untouched = ~ever & ~_inside(0.85, 1.0)
    np.testing.assert_array_equal(reused[untouched], plain[untouched])


def test_reuse_fades_to_the_raster_layer_over_the_fade_frames(device: str) -> None:
    """A still camera: frame 1 traces the left window, the next frames the right one.
    On the left, frame k shows raster + u (traced - raster), u = 1 - (k - 2) / FADE_FRAMES:
    whole one frame after, gone FADE_FRAMES frames later."""
    scene = _scene()
    cam = scene.cameras[0]
    full = _full(scene, cam)
    with Renderer(scene, _settings(device=device)) as r:
        raster = r.render(cam, _window(0.85)).color
    left = _inside(0.3) & ~_inside(0.85)
    with Renderer(scene, _settings(device=device, reuse=True)) as r:
        r.render(cam, _window(0.3))
        for k in range(2, FADE_FRAMES + 3):
            u = max(0.0, 1.0 - (k - 2) / FADE_FRAMES)
            shown = r.render(cam, _window(0.85)).color
            expected = raster[left] + u * (full[left] - raster[left])
            np.testing.assert_allclose(shown[left], expected, rtol=1e-4, atol=1e-5, err_msg=f"frame {k}")


def test_a_surface_that_moved_away_is_not_reused(device: str) -> None:
    """The box moves between frames (same camera): where its top was traced, frame 2
    sees the floor at another depth and reuses nothing (plain hybrid's values); where
    the floor stays floor it reuses."""
    before, after = _scene(-2.0), _scene(-4.0)
    cam = before.cameras[0]
    with Renderer(before, _settings(device=device, reuse=True)) as r:
        tri1 = r.render(cam, _window(0.3)).gbuffer.triangle_id.numpy().copy()  # the buffer is reused
        r.update_scene(dataclasses.replace(before, points=after.points))
        frame = r.render(cam, _window(0.85))
        reused, tri2 = frame.color, frame.gbuffer.triangle_id.numpy()
    with Renderer(after, _settings(device=device)) as r:
        plain = r.render(cam, _window(0.85)).color
    left = _inside(0.3) & ~_inside(0.85)
    uncovered = left & (tri1 >= 2) & (tri2 < 2)  # box then, floor now
    assert uncovered.sum() > 10
    np.testing.assert_array_equal(reused[uncovered], plain[uncovered])
    stayed = left & (tri1 < 2) & (tri2 < 2)
    assert np.abs(reused[stayed] - plain[stayed]).max() > 0.0


@pytest.mark.parametrize("mode", ["raster", "full"])
def test_reuse_runs_only_in_hybrid_mode(mode: str) -> None:
    """Ignored outside hybrid mode (no pass, as the ring)."""
    with Renderer(_scene(), _settings(mode=mode, reuse=True)) as r:
        assert not any(isinstance(p, TemporalReuse) for p in r.passes)
