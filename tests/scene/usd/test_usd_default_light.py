"""A stage with no lights is lit as usdview lights it: a headlight along the default
camera's view and a dim dome, with one warning."""

from __future__ import annotations

import math

import numpy as np
from pxr import Gf, UsdGeom, UsdLux
from render_kit import add_camera, render_aovs
from usd_stage_kit import add_mesh, bind, new_stage, preview_material, save_and_load

from warp_hybrid.scene.model import LightKind
from warp_hybrid.scene.usd.default_light import (
    DEFAULT_DOME_NAME,
    DEFAULT_DOME_RADIANCE,
    DEFAULT_LIGHT_WARNING,
    HEADLIGHT_IRRADIANCE,
    HEADLIGHT_NAME,
)
from warp_hybrid.scene.usd.loader import UsdSceneSource

ALBEDO = (0.5, 0.25, 0.125)


def _lambertian_quad_stage(tmp_path):
    """A 2x2 quad at z = 0 facing +Z with an exact Lambertian material (specular
    workflow, specularColor 0: the BRDF is albedo / pi), a camera on +Z, no lights."""
    stage, path = new_stage(tmp_path)
    quad = add_mesh(stage, "/World/Quad", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [4], [0, 1, 2, 3])
    mat, _ = preview_material(
        stage, "/World/Looks/Matte", diffuseColor=ALBEDO, useSpecularWorkflow=1, specularColor=(0.0, 0.0, 0.0)
    )
    bind(quad, mat)
    return stage, path


def test_headlight_lights_a_lambertian_quad_as_the_formula_says(tmp_path, device):
    stage, path = _lambertian_quad_stage(tmp_path)
    add_camera(stage, 3.0)
    scene = save_and_load(stage, path)
    assert [w for w in scene.warnings if "no lights" in w] == [DEFAULT_LIGHT_WARNING]
    (light,) = scene.lights
    assert light.name == HEADLIGHT_NAME and light.kind == LightKind.DISTANT
    np.testing.assert_allclose(light.direction, (0.0, 0.0, -1.0), atol=1e-12)  # along the camera's view
    assert scene.environment is not None and scene.environment.name == DEFAULT_DOME_NAME
    aovs = render_aovs(scene, device=device)
    hit = np.isfinite(aovs["depth"])
    assert hit.sum() > 200
    # Lambert: L = albedo / pi * E * n.l (n.l = 1: the light travels along -Z onto a +Z face)
    # plus the constant dome: albedo / pi * (pi L_dome) (its irradiance), Fresnel 0.
    expected = np.asarray(ALBEDO) * (HEADLIGHT_IRRADIANCE / math.pi + DEFAULT_DOME_RADIANCE)
    np.testing.assert_allclose(aovs["color"][hit], np.broadcast_to(expected, (hit.sum(), 3)), rtol=2e-3)
    np.testing.assert_allclose(aovs["color"][~hit], DEFAULT_DOME_RADIANCE, rtol=1e-4)  # the dim dome shows


def test_headlight_follows_the_default_camera_over_time(tmp_path):
    stage, path = _lambertian_quad_stage(tmp_path)
    cam = UsdGeom.Camera.Define(stage, "/World/Cam")
    turn = cam.AddRotateYOp()
    turn.Set(0.0, 0.0)
    turn.Set(90.0, 10.0)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(10)
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    first = source.scene_at(0.0)
    later = source.scene_at(10.0)
    np.testing.assert_allclose(first.lights[0].direction, (0.0, 0.0, -1.0), atol=1e-9)
    np.testing.assert_allclose(later.lights[0].direction, later.cameras[0].forward, atol=1e-9)
    np.testing.assert_allclose(later.lights[0].direction, (-1.0, 0.0, 0.0), atol=1e-9)  # -Z turned 90 deg about Y
    assert later.warnings.count(DEFAULT_LIGHT_WARNING) == 1


def test_a_stage_with_a_light_or_a_dome_gets_no_default_light(tmp_path):
    stage, path = _lambertian_quad_stage(tmp_path)
    UsdLux.DistantLight.Define(stage, "/World/Sun")
    scene = save_and_load(stage, path)
    assert [li.name for li in scene.lights] == ["/World/Sun"] and scene.environment is None
    stage2, path2 = _lambertian_quad_stage(tmp_path / "dome")
    UsdLux.DomeLight.Define(stage2, "/World/Sky").CreateColorAttr(Gf.Vec3f(0.5, 0.5, 0.5))
    scene2 = save_and_load(stage2, path2)
    assert scene2.lights == [] and scene2.environment.name == "/World/Sky"
    assert not [w for w in scene.warnings + scene2.warnings if "no lights" in w]
