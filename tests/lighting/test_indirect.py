"""The indirect-light estimate: each light's power against the lights' own irradiance
integrated over a sphere around it, the albedo and emission means, and the integrating
sphere, where the estimate is exact."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_lights import _sample

from warp_hybrid.lighting.indirect import (
    MAX_ALBEDO,
    emissive_power,
    indirect_irradiance,
    light_power,
    mean_albedo,
    triangle_areas,
)
from warp_hybrid.scene.authoring.builders import make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Light, LightKind, Material, TextureBinding, TextureImage

R = 40.0  # the integration sphere's radius, far beyond every light's size


def _fibonacci_sphere(count: int) -> np.ndarray:
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    phi = math.pi * (1.0 + 5.0**0.5) * k
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


LIGHTS = {
    "sphere": Light(LightKind.SPHERE, "s", (1.0, 2.0, 3.0), position=(0.5, 0.2, -0.1), radius=0.3),
    "sphere_normalized": Light(LightKind.SPHERE, "n", (1.0, 2.0, 3.0), radius=0.3, normalize=True),
    "point": Light(LightKind.SPHERE, "p", (2.0, 2.0, 2.0), position=(0.1, 0.0, 0.0)),
    "spot": Light(LightKind.SPHERE, "c", (2.0, 2.0, 2.0), direction=(0.0, 0.0, -1.0), cone_angle_deg=40.0),
    "rect": Light(
        LightKind.RECT,
        "r",
        (3.0, 3.0, 3.0),
        direction=(0.0, -1.0, 0.0),
        axis_u=(0.4, 0.0, 0.0),
        axis_v=(0.0, 0.0, 0.25),
    ),
    "disk": Light(LightKind.DISK, "d", (1.0, 1.0, 1.0), direction=(0.0, 0.0, -1.0), radius=0.5),
}


@pytest.mark.parametrize("name", sorted(LIGHTS))
def test_light_power_is_the_flux_of_the_lights_own_irradiance(device: str, name: str) -> None:
    """All the flux a light emits crosses a sphere around it: the irradiance
    ``lighting/lights.py`` gives on that sphere (inward normals), integrated over it,
    equals ``light_power`` to 1%."""
    light = LIGHTS[name]
    directions = _fibonacci_sphere(40000)
    centre = np.asarray(light.position, np.float64)
    points = centre + R * directions
    e = _sample(device, light, points, -directions)["irradiance"].astype(np.float64)
    flux = e.sum(axis=0) * (4.0 * math.pi * R * R / len(directions))
    np.testing.assert_allclose(flux, light_power(light, (np.zeros(3), np.ones(3))), rtol=0.01)


def test_a_distant_light_delivers_its_irradiance_across_the_scene_bounds() -> None:
    light = Light(LightKind.DISTANT, "sun", (2.0, 2.0, 2.0), direction=(0.0, -0.6, -0.8))
    lower, upper = np.zeros(3), np.array([3.0, 2.0, 1.0])
    # the box's shadow on a plane across the light: |d_y| x z-extent ... summed over the faces
    across = 0.6 * 3.0 * 1.0 + 0.8 * 3.0 * 2.0
    np.testing.assert_allclose(light_power(light, (lower, upper)), 2.0 * across)


def test_albedo_is_the_area_weighted_mean_of_the_diffuse_colours() -> None:
    """A 2 x 1 red quad, a 1 x 1 half-metal grey one and a 1 x 1 quad whose texture
    (texels rgb (0, 0.25, 0.5), scale 2, bias 0.1) gives (0.1, 0.6, 1.1), clipped to 1:
    the mean is weighted by area."""
    image = TextureImage("flat", np.stack([np.full((2, 2), v, np.float32) for v in (0.0, 0.25, 0.5, 1.0)], axis=-1))
    mean_rgb = np.array([0.1, 0.6, 1.1])
    scene = make_scene(
        [
            quad((0, 0, 0), (2, 0, 0), (0, 1, 0), 0, "/red"),
            quad((0, 2, 0), (1, 0, 0), (0, 1, 0), 1, "/metal"),
            quad((0, 4, 0), (1, 0, 0), (0, 1, 0), 2, "/textured"),
        ],
        [
            Material("red", diffuse=(0.8, 0.1, 0.1)),
            Material("metal", diffuse=(0.5, 0.5, 0.5), metallic=0.5),
            Material("tex", diffuse=(0.9, 0.9, 0.9), diffuse_texture=0),
        ],
        images=[image],
        textures=[TextureBinding(0, scale=(2.0, 2.0, 2.0, 1.0), bias=(0.1, 0.1, 0.1, 0.0))],
    )
    areas = triangle_areas(scene)
    np.testing.assert_allclose(areas.sum(), 4.0)
    expected = (2.0 * np.array([0.8, 0.1, 0.1]) + 0.25 * np.ones(3) + np.clip(mean_rgb, 0.0, 1.0)) / 4.0
    np.testing.assert_allclose(mean_albedo(scene, areas), expected, rtol=1e-6)


def test_emissive_surfaces_emit_pi_radiance_per_unit_area() -> None:
    scene = make_scene(
        [quad((0, 0, 0), (2, 0, 0), (0, 1, 0), 0), quad((0, 3, 0), (1, 0, 0), (0, 1, 0), 1, "/dark")],
        [Material("glow", emissive=(1.0, 2.0, 3.0)), Material("dark")],
    )
    np.testing.assert_allclose(emissive_power(scene, triangle_areas(scene)), math.pi * 2.0 * np.array([1.0, 2.0, 3.0]))


@pytest.mark.parametrize("rho", [0.2, 0.5, 0.8])
def test_the_estimate_is_the_integrating_sphere_result(rho: float) -> None:
    """A closed sphere of albedo rho around a point light of intensity I: the light the
    walls receive after the first hit is rho / (1 - rho) times the direct irradiance
    I / R^2 (Phi / A for the sphere), uniformly."""
    radius, intensity = 2.0, 3.0
    scene = make_scene(
        [uv_sphere((0.0, 0.0, 0.0), radius, rings=96, segments=192)],
        [Material("wall", diffuse=(rho, rho, rho))],
        lights=[Light(LightKind.SPHERE, "bulb", (intensity,) * 3)],
    )
    area = triangle_areas(scene).sum()
    assert area == pytest.approx(4.0 * math.pi * radius**2, rel=1e-3)
    expected = rho / (1.0 - rho) * 4.0 * math.pi * intensity / area
    np.testing.assert_allclose(indirect_irradiance(scene), expected, rtol=1e-9)
    assert expected == pytest.approx(rho / (1.0 - rho) * intensity / radius**2, rel=1e-3)


def test_a_white_room_is_capped_and_an_empty_scene_has_none() -> None:
    scene = make_scene(
        [uv_sphere((0.0, 0.0, 0.0), 1.0, rings=8, segments=16)],
        [Material("white", diffuse=(1.0, 1.0, 1.0))],
        lights=[Light(LightKind.SPHERE, "bulb", (1.0, 1.0, 1.0))],
    )
    e = indirect_irradiance(scene)
    np.testing.assert_allclose(e, MAX_ALBEDO / (1.0 - MAX_ALBEDO) * 4.0 * math.pi / triangle_areas(scene).sum())
    empty = make_scene([], [Material("m")], lights=[Light(LightKind.SPHERE, "bulb", (1.0, 1.0, 1.0))])
    np.testing.assert_array_equal(indirect_irradiance(empty), np.zeros(3))


def _integrating_sphere(rho: float):
    """A closed sphere (radius 2, albedo rho, no specular: F0 = 0) around a point light
    of intensity 3 at its centre, seen from the centre."""
    from warp_hybrid.scene.authoring.builders import look_at_camera

    camera = look_at_camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), hfov_deg=40.0, near=0.01, far=10.0)
    wall = Material("wall", diffuse=(rho, rho, rho), use_specular_workflow=True, specular=(0.0, 0.0, 0.0))
    return make_scene(
        [uv_sphere((0.0, 0.0, 0.0), 2.0, rings=96, segments=192)],
        [wall],
        lights=[Light(LightKind.SPHERE, "bulb", (3.0, 3.0, 3.0))],
        cameras=[camera],
    )


@pytest.mark.parametrize("mode", ["raster", "full"])
def test_both_layers_render_the_integrating_sphere_exactly(device: str, mode: str) -> None:
    """With the estimate on, the wall's radiance in the raster layer and in the traced
    layer is the integrating sphere's: rho / pi * (I / R^2) / (1 - rho), all
    interreflections included (to the tessellation's 0.2%); without it, the direct
    light alone."""
    from warp_hybrid.errors import RenderSettingsError
    from warp_hybrid.renderer import Renderer, RenderSettings
    from warp_hybrid.scene.device import DeviceScene

    rho = 0.6
    scene = _integrating_sphere(rho)
    direct = rho / math.pi * 3.0 / 4.0
    for indirect, expected in ((True, direct / (1.0 - rho)), (False, direct)):
        settings = RenderSettings(
            width=24, height=16, device=device, mode=mode, exposure_ev=0.0, antialias=False, indirect=indirect
        )
        with Renderer(scene, settings) as r:
            frame = r.render(scene.cameras[0])
        np.testing.assert_allclose(frame.color, expected, rtol=3e-3)
        assert ("indirect" in frame.stats["effects"]) == indirect
    # a device scene built one way cannot serve settings asking the other
    with pytest.raises(RenderSettingsError, match="built with indirect=False"):
        Renderer(DeviceScene(scene, device), RenderSettings(width=8, height=8, device=device, indirect=True))
