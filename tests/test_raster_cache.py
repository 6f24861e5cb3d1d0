"""``RenderSettings.cache_raster``: a still view keeps its raster layer across frames and
redraws only what depends on the window, bit for bit the frames a renderer without the
cache draws."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from warp_hybrid import Renderer, RenderSettings, open_scene_source
from warp_hybrid.focus import FocusWindow
from warp_hybrid.scene.model import Camera

CORNELL = Path(__file__).resolve().parents[1] / "scenes" / "cornell_glass.usda"
RASTER_STAGES = ("raster", "resolve", "surface", "lighting")


def _scene(blended: bool = False):
    scene = open_scene_source(CORNELL).scene_at(None)
    if blended:  # its glass as alpha coverage: the layer behind it is drawn too
        materials = [dataclasses.replace(m, alpha_blended=m.is_transmissive) for m in scene.materials]
        scene = dataclasses.replace(scene, materials=materials)
    return scene


def _moved(camera: Camera, dx: float) -> Camera:
    m = np.array(camera.cam_to_world, dtype=np.float64)
    m[0, 3] += dx
    return dataclasses.replace(camera, cam_to_world=m)


def _settings(**kw) -> RenderSettings:
    return RenderSettings(width=64, height=48, exposure_ev=None, threads=2, **kw)


def _window(gx: float) -> FocusWindow:
    return FocusWindow(gaze=(gx, 0.5), fraction=0.15)


@pytest.mark.parametrize(
    "extra",
    [{}, {"shadow_maps": True, "shadow_map_size": 64, "reuse": True}, {"ring": True, "probes": True}],
    ids=["plain", "maps+reuse", "ring+probes"],
)
@pytest.mark.parametrize("blended", [False, True])
def test_a_still_view_keeps_its_raster_layer_and_changes_nothing(device: str, extra: dict, blended: bool) -> None:
    """A sequence of frames (the gaze moving, then the camera, then the scene) drawn with
    and without the cache: every frame's image, colour and visibility equal; the raster
    stages are skipped exactly in the frames whose camera and scene stood still, and
    those frames trace fewer primary shadow rays (the pixels the last windows of the
    view covered keep theirs, ``trace/shadow_cache.py``), the others as many."""
    scene = _scene(blended)
    cam = scene.cameras[0]
    moved_points = dataclasses.replace(scene, points=scene.points + np.float32(0.01))
    steps = [
        (cam, 0.3, None, False),  # the first frame draws everything
        (cam, 0.6, None, True),  # the gaze moved: the raster layer is kept
        (cam, 0.7, None, True),
        (_moved(cam, 0.05), 0.7, None, False),  # the camera moved
        (_moved(cam, 0.05), 0.4, None, True),
        (_moved(cam, 0.05), 0.4, moved_points, False),  # the scene moved
        (_moved(cam, 0.05), 0.5, None, True),
    ]
    with (
        Renderer(scene, _settings(device=device, cache_raster=True, **extra)) as cached,
        Renderer(scene, _settings(device=device, **extra)) as plain,
    ):
        for i, (camera, gx, update, expect_cached) in enumerate(steps):
            if update is not None:
                cached.update_scene(update)
                plain.update_scene(update)
            a = cached.render(camera, _window(gx))
            b = plain.render(camera, _window(gx))
            assert a.stats["raster_cached"] is expect_cached, i
            assert b.stats["raster_cached"] is False
            skipped = [s for s in RASTER_STAGES if s not in a.stats["stages_ms"]]
            assert skipped == (list(RASTER_STAGES) if expect_cached else []), (i, skipped)
            shadow_rays = a.stats["rays"]["shadow"], b.stats["rays"]["shadow"]
            assert shadow_rays[0] < shadow_rays[1] if expect_cached else shadow_rays[0] == shadow_rays[1], i
            np.testing.assert_array_equal(a.image, b.image, err_msg=f"frame {i}")
            np.testing.assert_array_equal(a.color, b.color, err_msg=f"frame {i}")
            np.testing.assert_array_equal(a.visibility, b.visibility, err_msg=f"frame {i}")
            np.testing.assert_array_equal(a.aovs()["depth"], b.aovs()["depth"], err_msg=f"frame {i}")


@pytest.mark.parametrize("across", ["rows", "cols"])
def test_a_window_moving_across_the_frame_redraws_only_what_changed(device: str, across: str) -> None:
    """On a tall (wide) frame, the window jumps between rows (columns) far apart: the
    cached renderer restores only the rows the last window covered and redraws only the
    rows and columns either window touched (FXAA's reach around them), and every frame
    equals the uncached one."""
    scene = _scene()
    cam = scene.cameras[0]
    gazes = [(0.5, 0.1), (0.5, 0.9), (0.3, 0.5), (0.6, 0.1), (0.6, 0.12)]
    size = {"width": 40, "height": 160}
    if across == "cols":
        gazes = [(y, x) for x, y in gazes]
        size = {"width": 160, "height": 40}
    settings = {**size, "exposure_ev": None, "threads": 2, "device": device}
    with (
        Renderer(scene, RenderSettings(cache_raster=True, **settings)) as cached,
        Renderer(scene, RenderSettings(**settings)) as plain,
    ):
        for i, gaze in enumerate(gazes):
            window = FocusWindow(gaze=gaze, fraction=0.05)
            a, b = cached.render(cam, window), plain.render(cam, window)
            assert a.stats["raster_cached"] is (i > 0)
            span = cached.buffers.color_rows if across == "rows" else cached.buffers.color_cols
            assert span is not None and span[1] - span[0] < 60, span  # the window's rows (columns) only
            np.testing.assert_array_equal(a.image, b.image, err_msg=f"frame {i}")
            np.testing.assert_array_equal(a.color, b.color, err_msg=f"frame {i}")


@pytest.mark.parametrize("mode", ["raster", "full"])
def test_the_cache_in_raster_and_full_modes(mode: str) -> None:
    """Raster mode keeps its frame for a still view (the same image again); full mode has
    no raster layer and draws every frame."""
    scene = _scene()
    with Renderer(scene, _settings(mode=mode, cache_raster=True)) as r:
        first = r.render(scene.cameras[0])
        again = r.render(scene.cameras[0])
        assert again.stats["raster_cached"] is (mode == "raster")
        np.testing.assert_array_equal(first.image, again.image)


def test_a_resize_draws_the_raster_layer_again() -> None:
    """New buffers (a resize) hold no raster layer to keep."""
    scene = _scene()
    with Renderer(scene, _settings(mode="raster", cache_raster=True)) as r:
        r.render(scene.cameras[0])
        r.resize(32, 24)
        frame = r.render(scene.cameras[0])
        assert frame.stats["raster_cached"] is False and frame.image.shape == (24, 32, 3)
        assert r.render(scene.cameras[0]).stats["raster_cached"] is True


def _mesh_moved(scene, prim: str, offset) -> object:
    """``scene`` with the mesh ``prim``'s points moved by ``offset`` (a new points array)."""
    r = next(m for m in scene.meshes if m.prim_path == prim)
    points = scene.points.copy()
    points[r.first_point : r.first_point + r.point_count] += np.asarray(offset, dtype=np.float32)
    return dataclasses.replace(scene, points=points)


@pytest.mark.parametrize(("mode", "primary"), [("hybrid", "raster"), ("raster", "raster"), ("hybrid", "raycast")])
def test_a_small_moving_mesh_redraws_only_the_rows_it_can_cover(device: str, mode: str, primary: str) -> None:
    """The prism slides while the view stands still: the cached renderer draws only the
    rows its old and new places project to, and every frame (image, colour, every
    G-buffer channel) equals the uncached renderer's, which draws every row."""
    scene = _scene()
    cam = scene.cameras[0]
    with (
        Renderer(scene, _settings(device=device, mode=mode, primary=primary, cache_raster=True)) as cached,
        Renderer(scene, _settings(device=device, mode=mode, primary=primary)) as plain,
    ):
        current = scene
        for i in range(5):
            if i > 0:
                current = _mesh_moved(current, "/World/Geom/GlassPrism", (0.05, -0.2 if i < 3 else 0.3, 0.0))
                cached.update_scene(current)
                plain.update_scene(current)
            a = cached.render(cam, _window(0.5))
            b = plain.render(cam, _window(0.5))
            rows = a.stats["raster_rows"]
            if i == 0:
                assert rows is None
            else:
                assert rows is not None and rows[1] - rows[0] < 40, (i, rows)
                drawn = RASTER_STAGES if primary == "raster" else ("raycast", "surface", "lighting")
                assert a.stats["stages_ms"].keys() >= set(drawn)
            assert b.stats["raster_rows"] is None
            np.testing.assert_array_equal(a.image, b.image, err_msg=f"frame {i}")
            np.testing.assert_array_equal(a.color, b.color, err_msg=f"frame {i}")
            for name, channel in a.aovs().items():
                np.testing.assert_array_equal(channel, b.aovs()[name], err_msg=f"frame {i}: {name}")


def test_what_a_moving_mesh_cannot_redraw_in_part(device: str) -> None:
    """Every row is drawn again where the moved mesh reaches the near plane, where the
    update changed more than geometry (a light), and with shadow maps (a mesh's shadow
    falls anywhere); the frames still equal the uncached ones."""
    scene = _scene()
    cam = scene.cameras[0]
    behind = (
        np.asarray(cam.position, dtype=np.float32)
        - scene.points[next(m for m in scene.meshes if m.prim_path == "/World/Geom/GlassPrism").first_point]
    )
    lit = dataclasses.replace(scene, lights=[dataclasses.replace(scene.lights[0], color=(2.0, 2.0, 2.0))])
    cases = [
        ({}, _mesh_moved(scene, "/World/Geom/GlassPrism", behind)),  # across the camera's near plane
        ({}, _mesh_moved(lit, "/World/Geom/GlassPrism", (0.04, 0.0, 0.0))),  # and a light changed
        ({"shadow_maps": True, "shadow_map_size": 64}, _mesh_moved(scene, "/World/Geom/GlassPrism", (0.04, 0.0, 0.0))),
    ]
    for i, (extra, update) in enumerate(cases):
        with (
            Renderer(scene, _settings(device=device, cache_raster=True, **extra)) as cached,
            Renderer(scene, _settings(device=device, **extra)) as plain,
        ):
            cached.render(cam, _window(0.5))
            plain.render(cam, _window(0.5))
            cached.update_scene(update)
            plain.update_scene(update)
            a, b = cached.render(cam, _window(0.5)), plain.render(cam, _window(0.5))
            assert a.stats["raster_rows"] is None and not a.stats["raster_cached"], i
            np.testing.assert_array_equal(a.image, b.image, err_msg=f"case {i}")
            np.testing.assert_array_equal(a.color, b.color, err_msg=f"case {i}")
