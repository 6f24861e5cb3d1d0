"""Deferred lighting on G-buffers filled from numpy (no rasterizer needed)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.lighting.deferred import DeferredLighting
from warp_hybrid.parallel import Launcher
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Environment, Light, LightKind, Material
from warp_hybrid.timing import StageTimer

H, W = 12, 16


def _plane_gbuffer(
    device,
    albedo=(0.6, 0.4, 0.2),
    specular=(0.0, 0.0, 0.0),
    roughness=0.5,
    opacity=1.0,
    ior=1.5,
    emission=(0.0, 0.0, 0.0),
    material=0,
    background_cols=0,
) -> GBuffer:
    """Every pixel sees the plane y = 0 (normal +Y) at x = column - W/2, z = row - H/2;
    the first ``background_cols`` columns are background."""
    gb = GBuffer(W, H, device)
    rows, cols = np.mgrid[0:H, 0:W].astype(np.float32)
    pos = np.stack([cols - W / 2, np.zeros_like(cols), rows - H / 2], axis=-1)
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 1] = 1.0
    hit = np.ones((H, W), bool)
    hit[:, :background_cols] = False

    def fill(value) -> np.ndarray:
        return np.broadcast_to(np.asarray(value, np.float32), (H, W, len(value))).copy()

    gb.position.assign(pos)
    gb.normal.assign(normal)
    gb.geometric_normal.assign(normal)
    gb.depth.assign(np.where(hit, 1.0, np.inf).astype(np.float32))
    gb.albedo.assign(fill(albedo))
    gb.specular.assign(fill(specular))
    gb.emission.assign(fill(emission))
    optics = np.zeros((H, W), dtype=gb.optics.numpy().dtype)
    for name, value in zip(("reflectivity", "ior", "opacity", "roughness"), (max(specular), ior, opacity, roughness)):
        optics[name] = value
    gb.optics.assign(optics)
    gb.material_id.assign(np.where(hit, material, -1).astype(np.int32))
    gb.triangle_id.assign(np.where(hit, 0, -1).astype(np.int32))
    return gb


def _scene(device, lights=(), environment=None, materials=None) -> DeviceScene:
    mats = materials or [Material("/m")]
    return DeviceScene(
        make_scene([quad((0, 0, 0), (1, 0, 0), (0, 0, 1))], mats, lights=list(lights), environment=environment), device
    )


def _shade(device, ds, gb, threads=None, eye=(0.0, 5.0, 8.0)) -> np.ndarray:
    cam = make_camera_gpu(look_at_camera(eye, (0.0, 0.0, 0.0)), W, H)
    out = wp.zeros((H, W), dtype=wp.vec3, device=device)
    with Launcher(device, threads=threads) as launcher:
        DeferredLighting(launcher).shade(ds, cam, gb, out, StageTimer())
    return out.numpy()


def test_lambert_plane_under_distant_light(device):
    albedo = np.array([0.6, 0.4, 0.2])
    for theta in (0.0, 35.0, 80.0, 100.0):
        t = math.radians(theta)
        sun = Light(LightKind.DISTANT, "/sun", (3.0, 3.0, 3.0), direction=(math.sin(t), -math.cos(t), 0.0))
        color = _shade(device, _scene(device, [sun]), _plane_gbuffer(device, albedo=tuple(albedo)))
        expected = albedo / math.pi * 3.0 * max(math.cos(t), 0.0)
        np.testing.assert_allclose(color.reshape(-1, 3), np.tile(expected, (H * W, 1)), rtol=1e-6, atol=1e-7)


def test_point_light_inverse_square_on_plane(device):
    bulb = Light(LightKind.SPHERE, "/bulb", (10.0, 10.0, 10.0), position=(1.0, 2.0, -1.0), radius=0.0)
    gb = _plane_gbuffer(device, albedo=(0.5, 0.5, 0.5))
    color = _shade(device, _scene(device, [bulb]), gb)
    pos = gb.position.numpy()
    d = np.array([1.0, 2.0, -1.0]) - pos
    d2 = np.sum(d * d, axis=-1)
    expected = 0.5 / math.pi * 10.0 * (2.0 / np.sqrt(d2)) / d2
    np.testing.assert_allclose(color[..., 0], expected, rtol=1e-5)


def test_constant_dome_ambient_emission_and_background(device):
    dome = Environment("/dome", (0.3, 0.5, 0.7))
    albedo = np.array([0.6, 0.4, 0.2])
    gb = _plane_gbuffer(device, albedo=tuple(albedo), emission=(0.1, 0.0, 0.0), background_cols=3)
    glow = [Material("/m", emissive=(0.1, 0.0, 0.0))]  # (the G-buffer's emission is the scene's)
    color = _shade(device, _scene(device, environment=dome, materials=glow), gb)
    # SH irradiance of a constant dome is pi L, so a Lambertian returns albedo * L
    np.testing.assert_allclose(
        color[:, 3:].reshape(-1, 3), np.tile(albedo * [0.3, 0.5, 0.7] + [0.1, 0, 0], (H * (W - 3), 1)), rtol=1e-5
    )
    np.testing.assert_allclose(color[:, :3].reshape(-1, 3), np.tile([0.3, 0.5, 0.7], (H * 3, 1)), rtol=1e-6)
    dark = _shade(device, _scene(device), _plane_gbuffer(device, background_cols=3))
    np.testing.assert_array_equal(dark, 0.0)


def test_specular_surface_in_a_white_furnace(device):
    # a smooth grey dielectric under a uniform dome reflects about what it receives
    dome = Environment("/dome", (1.0, 1.0, 1.0))
    color = _shade(
        device,
        _scene(device, environment=dome),
        _plane_gbuffer(device, albedo=(0.96, 0.96, 0.96), specular=(0.04, 0.04, 0.04), roughness=0.3),
    )
    assert 0.93 <= color.min() and color.max() <= 1.0 + 1e-4
    metal = _shade(
        device,
        _scene(device, environment=dome),
        _plane_gbuffer(device, albedo=(0, 0, 0), specular=(1.0, 0.8, 0.3), roughness=0.0),
    )
    # the centre pixel is the origin, seen from (0, 5, 8): Schlick's F at that angle
    f0 = np.array([1.0, 0.8, 0.3])
    n_dot_v = 5.0 / math.sqrt(89.0)
    np.testing.assert_allclose(metal[H // 2, W // 2], f0 + (1.0 - f0) * (1.0 - n_dot_v) ** 5, rtol=0.01)


def test_lights_add_up(device):
    sun = Light(LightKind.DISTANT, "/sun", (2.0, 2.0, 2.0), direction=(0.0, -1.0, 0.0))
    bulb = Light(LightKind.SPHERE, "/bulb", (5.0, 5.0, 5.0), position=(0.0, 3.0, 0.0), radius=0.0)
    ds = _scene(device, [sun, bulb])
    gb = _plane_gbuffer(device, specular=(0.04, 0.04, 0.04), roughness=0.4)
    only_sun = _shade(device, _scene(device, [sun]), gb)
    only_bulb = _shade(device, _scene(device, [bulb]), gb)
    both = _shade(device, ds, gb)
    np.testing.assert_allclose(both, only_sun + only_bulb, rtol=1e-5)


def test_transmissive_raster_approximation(device):
    glass = Material("/glass", diffuse=(1.0, 1.0, 1.0), opacity=0.0, ior=1.5, roughness=0.0)
    assert glass.is_transmissive
    red_pane = Material("/pane", diffuse=(1.0, 0.0, 0.0), opacity=0.0, ior=1.5, roughness=0.0)
    dome = Environment("/dome", (1.0, 1.0, 1.0))
    mats = [glass, red_pane]
    top = (0.0, 8.0, 0.01)  # look straight down: normal incidence
    clear = _shade(
        device,
        _scene(device, environment=dome, materials=mats),
        _plane_gbuffer(device, albedo=(1, 1, 1), specular=(0.04,) * 3, roughness=0.0, opacity=0.0),
        eye=top,
    )
    # Fresnel reflection of the dome (~4%) + the dome seen through (~96%)
    np.testing.assert_allclose(clear[H // 2, W // 2], 1.0, atol=0.02)
    red = _shade(
        device,
        _scene(device, environment=dome, materials=mats),
        _plane_gbuffer(device, albedo=(1, 0, 0), specular=(0.04,) * 3, roughness=0.0, opacity=0.0, material=1),
        eye=top,
    )
    px = red[H // 2, W // 2]
    assert px[0] == pytest.approx(1.0, abs=0.02) and 0.02 < px[1] < 0.06 and px[1] == pytest.approx(px[2])
    # without a dome, glass is lit like a tinted Lambertian weighted by (1 - F)
    sun = Light(LightKind.DISTANT, "/sun", (3.0, 3.0, 3.0), direction=(0.0, -1.0, 0.0))
    lit = _shade(
        device,
        _scene(device, [sun], materials=mats),
        _plane_gbuffer(device, albedo=(1, 1, 1), specular=(0.0,) * 3, opacity=0.0),
        eye=top,
    )
    assert lit[H // 2, W // 2, 0] == pytest.approx(3.0 / math.pi * 0.96, rel=0.01)


def test_two_threads_match_one(device):
    sun = Light(LightKind.DISTANT, "/sun", (2.0, 2.0, 2.0), direction=(0.3, -1.0, 0.2))
    ds = _scene(device, [sun], environment=Environment("/dome", (0.2, 0.2, 0.3)))
    gb = _plane_gbuffer(device, specular=(0.04, 0.04, 0.04), roughness=0.25, background_cols=2)
    np.testing.assert_array_equal(_shade(device, ds, gb, threads=1), _shade(device, ds, gb, threads=2))


def test_a_mismatched_output_is_refused(device):
    sun = Light(LightKind.DISTANT, "/sun", (3.0, 3.0, 3.0), direction=(0.0, -1.0, 0.0))
    ds, gb = _scene(device, [sun]), _plane_gbuffer(device)
    cam = make_camera_gpu(look_at_camera((0.0, 5.0, 8.0), (0.0, 0.0, 0.0)), W, H)
    with Launcher(device) as launcher, pytest.raises(ValueError, match="must match the G-buffer"):
        DeferredLighting(launcher).shade(ds, cam, gb, wp.zeros((2, 2), dtype=wp.vec3, device=device), StageTimer())
