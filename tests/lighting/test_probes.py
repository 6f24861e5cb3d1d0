"""Reflection probes for the raster layer: a probe inside a uniformly emissive box holds
that radiance in every direction, a mirror seen by the raster layer reflects what full
ray tracing shows, the probe is captured again only when the scene changes, and with
the switch off every pixel is as before."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from bad_input_kit import run_cli
from scipy.ndimage import binary_erosion, maximum_filter, minimum_filter

from warp_hybrid import Renderer, RenderSettings, cli
from warp_hybrid.errors import ArgumentTypeError
from warp_hybrid.lighting.deferred import SHADE_KERNELS, DeferredLighting
from warp_hybrid.lighting.probes import PROBE_SIZE, ReflectionProbe, level_sizes, probe_position
from warp_hybrid.memory import probe_bytes
from warp_hybrid.scene.authoring.builders import MeshInput, look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Light, LightKind, Material, Scene

W, H = 64, 48
WALL = (0.3, 0.5, 0.7)


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float], material: int) -> list[MeshInput]:
    """An axis-aligned box as six quads."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    return [
        quad((x0, y0, z1), (dx, 0, 0), (0, dy, 0), material),
        quad((x1, y0, z0), (-dx, 0, 0), (0, dy, 0), material),
        quad((x1, y0, z1), (0, 0, -dz), (0, dy, 0), material),
        quad((x0, y0, z0), (0, 0, dz), (0, dy, 0), material),
        quad((x0, y1, z1), (dx, 0, 0), (0, 0, -dz), material),
        quad((x0, y0, z0), (dx, 0, 0), (0, 0, dz), material),
    ]


def _settings(mode: str, **extra: object) -> RenderSettings:
    return RenderSettings(width=W, height=H, mode=mode, antialias=False, exposure_ev=0.0, **extra)


def _probe(renderer: Renderer) -> ReflectionProbe | None:
    return next((p for p in renderer.passes if isinstance(p, ReflectionProbe)), None)


def _emissive_box(mirror: bool = False) -> Scene:
    """A closed box (-2..2)^3 whose walls emit ``WALL`` and reflect nothing, the camera
    inside looking down; with ``mirror`` a chrome plate (F0 = 1, smooth) just above its
    floor (it occludes no wall from the camera: everything it reflects lies above it)."""
    mats = [
        Material("/wall", diffuse=(0.0, 0.0, 0.0), emissive=WALL, roughness=1.0),
        Material("/chrome", diffuse=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.0),
    ]
    meshes = _box((-2.0, -2.0, -2.0), (2.0, 2.0, 2.0), 0)
    if mirror:
        meshes.append(quad((-1.5, -1.9, 1.5), (3.0, 0.0, 0.0), (0.0, 0.0, -3.0), 1))
    cam = look_at_camera((0.3, 0.5, 1.2), (0.0, -1.9, -0.3), hfov_deg=50.0)
    return make_scene(meshes, mats, cameras=[cam])


def test_probe_in_an_emissive_box_holds_its_radiance(device: str) -> None:
    """Every texel of every level sees a wall (coverage 1) of radiance ``WALL`` (float32
    rounding: 1e-5); a chrome plate in the box reflects it in the raster layer (F0 = 1
    at roughness 0, within 1e-3: measured 3.5e-5) as in full ray tracing, and is black
    without the probe."""
    with Renderer(_emissive_box(), _settings("raster", device=device, probes=True)) as r:
        r.render(_emissive_box().cameras[0])
        probe = _probe(r)
        assert probe is not None and probe.captures == 1
        texels = probe.gpu.texels.numpy()
        sizes = probe.gpu.size.numpy().tolist()
    assert sizes == level_sizes(PROBE_SIZE) == [64, 32, 16, 8]
    assert texels.shape == (6 * sum(s * s for s in sizes), 4)
    np.testing.assert_allclose(texels[:, :3], np.broadcast_to(WALL, (len(texels), 3)), rtol=1e-5)
    np.testing.assert_allclose(texels[:, 3], 1.0, rtol=1e-6)

    scene = _emissive_box(mirror=True)
    cam = scene.cameras[0]
    with Renderer(scene, _settings("raster", device=device, probes=True)) as r:
        frame = r.render(cam)
    plate = binary_erosion(frame.gbuffer.material_id.numpy() == 1, iterations=1)
    assert plate.sum() > 0.3 * W * H
    expected = np.broadcast_to(WALL, (int(plate.sum()), 3))
    np.testing.assert_allclose(frame.color[plate], expected, rtol=1e-3)
    with Renderer(scene, _settings("full", device=device)) as r:
        np.testing.assert_allclose(r.render(cam).color[plate], expected, rtol=1e-3)
    with Renderer(scene, _settings("raster", device=device)) as r:
        assert float(np.abs(r.render(cam).color[plate]).max()) == 0.0


def _mirror_and_wall() -> Scene:
    """A smooth metal mirror on the floor (F0 0.9, 0.8, 0.7) facing an emissive wall
    behind it, red left of x = 0 and blue right of it; no lights."""
    mats = [
        Material("/mirror", diffuse=(0.9, 0.8, 0.7), metallic=1.0, roughness=0.0),
        Material("/red", diffuse=(0.0, 0.0, 0.0), emissive=(2.0, 0.2, 0.2), roughness=1.0),
        Material("/blue", diffuse=(0.0, 0.0, 0.0), emissive=(0.2, 0.2, 2.0), roughness=1.0),
    ]
    meshes = [
        quad((-2.0, 0.0, 2.0), (4.0, 0.0, 0.0), (0.0, 0.0, -4.0), 0),
        quad((-10.0, 0.0, -3.0), (10.0, 0.0, 0.0), (0.0, 20.0, 0.0), 1),
        quad((0.0, 0.0, -3.0), (10.0, 0.0, 0.0), (0.0, 20.0, 0.0), 2),
    ]
    cam = look_at_camera((0.5, 2.0, 4.0), (0.0, 0.0, -0.5), hfov_deg=60.0)
    return make_scene(meshes, mats, cameras=[cam])


@pytest.mark.parametrize("mode", ["raster", "hybrid"])
def test_mirror_reflects_what_full_ray_tracing_shows(device: str, mode: str) -> None:
    """The mirror's pixels of the raster layer with the probe (raster mode; and a hybrid
    frame's periphery, the window in a corner off the mirror) match full ray tracing's
    within 1e-3 (measured 2e-7: both weigh the reflection with the split-sum table, and
    parallax correction against the wall, the box's own face, is exact), away from the
    wall's colour edge (2 pixels of the traced image: the probe's texels there) and the
    mirror's rim; without the probe they are black."""
    scene = _mirror_and_wall()
    cam = scene.cameras[0]
    with Renderer(scene, _settings("full", device=device)) as r:
        traced = r.render(cam)
    ids = traced.gbuffer.material_id.numpy()
    luma = traced.color.sum(axis=-1)
    red = traced.color[..., 0] > traced.color[..., 2]
    flat = maximum_filter(red, size=5) == minimum_filter(red, size=5)
    mirror = binary_erosion(ids == 0, iterations=2) & flat & (luma > 0.0)
    assert mirror.sum() > 300 and red[mirror].any() and (~red[mirror]).any(), "both halves are reflected"
    extra = {"window_fraction": 0.05} if mode == "hybrid" else {}
    with Renderer(scene, _settings(mode, device=device, probes=True, **extra)) as r:
        window = r.default_window((0.05, 0.05)) if mode == "hybrid" else None  # in a corner, off the mirror
        lit = r.render(cam, window).color
    np.testing.assert_allclose(lit[mirror], traced.color[mirror], rtol=1e-3, atol=1e-6)
    with Renderer(scene, _settings("raster", device=device)) as r:
        assert float(np.abs(r.render(cam).color[mirror]).max()) == 0.0


def test_probe_is_captured_again_only_when_the_scene_changes(device: str) -> None:
    """Captured at warm-up, not in the frames after (stage "probes" each frame) nor for
    a moved camera; again for moved points, a moved light and a new light colour (the
    probe holds the light); full mode has no probe pass."""
    light = Light(LightKind.SPHERE, "/bulb", (20.0, 20.0, 20.0), position=(0.0, 1.5, 0.0), radius=0.1)
    scene = dataclasses.replace(_emissive_box(mirror=True), lights=[light])
    cam = scene.cameras[0]
    with Renderer(scene, _settings("raster", device=device, probes=True)) as r:
        probe = _probe(r)
        r.warm_up(cam)
        assert probe.captures == 1
        for _ in range(2):
            assert "probes" in r.render(cam).stats["stages_ms"]
        moved_cam = look_at_camera((-0.5, 0.1, 1.2), (0.0, -1.9, -0.5), hfov_deg=50.0)
        r.render(moved_cam)
        assert probe.captures == 1
        scene = dataclasses.replace(scene, points=scene.points * np.float32(0.99), time=1.0)
        r.update_scene(scene)
        r.render(cam)
        r.render(cam)
        assert probe.captures == 2
        light = dataclasses.replace(light, position=(0.5, 1.5, 0.0))
        scene = dataclasses.replace(scene, lights=[light])
        r.update_scene(scene)
        r.render(cam)
        assert probe.captures == 3
        r.update_scene(dataclasses.replace(scene, lights=[dataclasses.replace(light, color=(1.0, 2.0, 3.0))]))
        r.render(cam)
        assert probe.captures == 4
        r.render(cam)
        assert probe.captures == 4
    with Renderer(scene, _settings("full", device=device, probes=True)) as r:
        assert _probe(r) is None


@pytest.mark.parametrize("mode", ["raster", "hybrid"])
def test_off_is_bit_identical(device: str, mode: str) -> None:
    """With probes off (the default) no probe pass runs, the lighting kernel is the
    lighting module's own, and every pixel equals a render with the switch off
    explicitly."""
    scene = _mirror_and_wall()
    cam = scene.cameras[0]
    frames = []
    for settings in (_settings(mode, device=device), _settings(mode, device=device, probes=False)):
        with Renderer(scene, settings) as r:
            assert _probe(r) is None
            lighting = next(p for p in r.passes if isinstance(p, DeferredLighting))
            assert lighting.probe is None
            frames.append(r.render(cam))
            assert "probes" not in frames[-1].stats["stages_ms"]
    assert SHADE_KERNELS[False].module.name == "warp_hybrid.lighting.deferred"
    assert np.array_equal(frames[0].color, frames[1].color)
    assert np.array_equal(frames[0].image, frames[1].image)


def test_probe_stands_in_free_space_the_camera_sees(device: str) -> None:
    """Inside the bounds: the camera's position.  Outside: the bounds' nearest point
    10% of their extent inside, or in front of the first surface on the way there
    (within float32 rounding)."""
    scene = _mirror_and_wall()  # bounds x -10..10, y 0..20, z -3..2
    with Renderer(scene, _settings("raster", device=device)) as r:
        ds = r.device_scene
        inside = np.array([0.5, 2.0, 1.0])
        np.testing.assert_array_equal(probe_position(ds, inside), inside)
        np.testing.assert_allclose(probe_position(ds, np.array([0.5, 2.0, 4.0])), [0.5, 2.0, 1.5], rtol=1e-6)
        # Below the floor: the way up to the bounds' inner box crosses the mirror at y = 0.
        below = probe_position(ds, np.array([0.0, -1.0, 0.0]))
        np.testing.assert_allclose(below, [0.0, -0.2, 0.0], atol=1e-5)  # 1% of the 20-unit scene before it


def test_settings_cli_and_memory() -> None:
    """A non-bool switch names the field; --probes maps to the setting on render, replay,
    view and bench; the memory estimate counts the probe only when it is on."""
    with pytest.raises(ArgumentTypeError, match=r"RenderSettings.probes must be True or False, got str 'yes'"):
        RenderSettings(probes="yes").validate()  # type: ignore[arg-type]
    parser = cli.build_parser()
    for command in (
        ["render", "x.usda", "-o", "x.png"],
        ["replay", "x.usda", "--gaze", "0.5,0.5", "--out", "x.mp4"],
        ["view", "x.usda"],
    ):
        assert cli._render_settings(parser.parse_args([*command, "--probes"])).probes is True
        assert cli._render_settings(parser.parse_args(command)).probes is False
    assert parser.parse_args(["bench", "x.usda", "--gaze", "0.5,0.5", "--out", "d", "--probes"]).probes is True
    assert probe_bytes(0, 2, 1000) == 0
    levels = 6 * (64 * 64 + 32 * 32 + 16 * 16 + 8 * 8) + 6
    assert probe_bytes(PROBE_SIZE, 2, 1000) > 16 * levels + 24 * 1000


def test_bad_cli_value_is_one_line(capsys: pytest.CaptureFixture) -> None:
    """--probes takes no value: one line, exit status 2."""
    run = run_cli(capsys, ["render", "missing.usda", "-o", "x.png", "--probes=yes"])
    assert run.code == 2 and len(run.err) == 1
