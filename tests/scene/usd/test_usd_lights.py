"""UsdLux lights: world position, direction, extent and colour * intensity * 2^exposure."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdLux
from usd_stage_kit import new_stage, save_and_load, unit_quad

from warp_hybrid.scene.model import LightKind, Wrap


def _light(scene, name):
    return next(li for li in scene.lights if li.name == name)


def test_distant_sphere_rect_disk_lights(tmp_path):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Floor")
    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.AddRotateXOp().Set(-90.0)  # local -Z points down
    sun.CreateColorAttr(Gf.Vec3f(1.0, 0.5, 0.25))
    sun.CreateIntensityAttr(3.0)
    sun.CreateExposureAttr(2.0)
    sun.CreateAngleAttr(1.5)

    spot = UsdLux.SphereLight.Define(stage, "/World/Spot")
    spot.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
    spot.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    spot.CreateRadiusAttr(0.5)
    spot.CreateIntensityAttr(10.0)
    spot.CreateExposureAttr(-1.0)
    shaping = UsdLux.ShapingAPI.Apply(spot.GetPrim())
    shaping.CreateShapingConeAngleAttr(30.0)
    shaping.CreateShapingConeSoftnessAttr(0.2)

    point = UsdLux.SphereLight.Define(stage, "/World/Point")
    point.CreateRadiusAttr(0.3)
    point.CreateTreatAsPointAttr(True)

    rect = UsdLux.RectLight.Define(stage, "/World/Rect")
    rect.AddTranslateOp().Set(Gf.Vec3d(0, 5, 0))
    rect.AddRotateYOp().Set(90.0)
    rect.AddScaleOp().Set(Gf.Vec3f(3, 3, 3))
    rect.CreateWidthAttr(2.0)
    rect.CreateHeightAttr(4.0)
    rect.CreateNormalizeAttr(True)

    disk = UsdLux.DiskLight.Define(stage, "/World/Disk")
    disk.AddTranslateOp().Set(Gf.Vec3d(0, 0, -2))
    disk.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    disk.CreateRadiusAttr(0.5)
    disk.CreateEnableColorTemperatureAttr(True)
    disk.CreateColorTemperatureAttr(3000.0)

    scene = save_and_load(stage, path)
    assert [li.name for li in scene.lights] == [
        "/World/Sun",
        "/World/Spot",
        "/World/Point",
        "/World/Rect",
        "/World/Disk",
    ]

    s = _light(scene, "/World/Sun")
    assert s.kind == LightKind.DISTANT and s.angle_deg == pytest.approx(1.5)
    np.testing.assert_allclose(s.direction, (0, -1, 0), atol=1e-6)
    np.testing.assert_allclose(s.color, (12.0, 6.0, 3.0), rtol=1e-6)

    sp = _light(scene, "/World/Spot")
    assert sp.kind == LightKind.SPHERE and sp.radius == pytest.approx(1.0)
    np.testing.assert_allclose(sp.position, (1, 2, 3), atol=1e-6)
    np.testing.assert_allclose(sp.color, (5.0, 5.0, 5.0), rtol=1e-6)
    assert (sp.cone_angle_deg, sp.cone_softness) == pytest.approx((30.0, 0.2))

    pt = _light(scene, "/World/Point")
    assert pt.radius == 0.0 and pt.cone_angle_deg == 180.0

    r = _light(scene, "/World/Rect")
    assert r.kind == LightKind.RECT and r.normalize
    np.testing.assert_allclose(r.position, (0, 5, 0), atol=1e-6)
    np.testing.assert_allclose(r.axis_u, (0, 0, -3), atol=1e-6)  # local X * half width, rotated and scaled
    np.testing.assert_allclose(r.axis_v, (0, 6, 0), atol=1e-6)
    np.testing.assert_allclose(r.direction, (-1, 0, 0), atol=1e-6)  # local -Z

    d = _light(scene, "/World/Disk")
    assert d.kind == LightKind.DISK and d.radius == pytest.approx(1.0)
    np.testing.assert_allclose(d.axis_u, (1, 0, 0), atol=1e-6)
    np.testing.assert_allclose(d.position, (0, 0, -2), atol=1e-6)
    np.testing.assert_allclose(d.color, np.asarray(UsdLux.BlackbodyTemperatureAsRgb(3000.0)), rtol=1e-6)
    assert d.color[0] > d.color[2]  # warm


def test_dome_light_texture_and_rotation(tmp_path):
    hdr = np.zeros((4, 8, 3), np.float32)
    hdr[0] = (0.5, 1.0, 4.0)  # BGR: top row
    assert cv2.imwrite(str(tmp_path / "sky.hdr"), hdr)
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Floor")
    dome = UsdLux.DomeLight.Define(stage, "/World/Sky")
    dome.AddRotateYOp().Set(90.0)
    dome.AddScaleOp().Set(Gf.Vec3f(5, 5, 5))
    dome.CreateTextureFileAttr("sky.hdr")
    dome.CreateIntensityAttr(0.5)
    dome.CreateExposureAttr(1.0)
    UsdLux.DomeLight.Define(stage, "/World/SecondSky")
    UsdLux.CylinderLight.Define(stage, "/World/Tube")
    scene = save_and_load(stage, path)
    env = scene.environment
    assert env is not None and env.name == "/World/Sky"
    np.testing.assert_allclose(env.color, (1.0, 1.0, 1.0), rtol=1e-6)
    binding = scene.textures[env.texture]
    assert (binding.wrap_s, binding.wrap_t) == (Wrap.REPEAT, Wrap.CLAMP)
    img = scene.images[binding.image]
    np.testing.assert_allclose(img.pixels[0, 0], (4.0, 1.0, 0.5, 1.0), rtol=1e-2)  # float image: raw, RGB
    # The dome turned +90 degrees about Y: its local +X faces world -Z.
    np.testing.assert_allclose(env.world_to_light @ np.array([0.0, 0.0, -1.0]), (1, 0, 0), atol=1e-6)
    np.testing.assert_allclose(env.world_to_light @ env.world_to_light.T, np.eye(3), atol=1e-6)  # scale removed
    assert scene.lights == []
    assert any(w.startswith("/World/SecondSky:") and "only the first DomeLight" in w for w in scene.warnings)
    assert any(w.startswith("/World/Tube:") and "CylinderLight" in w for w in scene.warnings)


def test_constant_dome_and_z_pole_dome_light_1(tmp_path):
    stage, path = new_stage(tmp_path, up_axis="Z")
    unit_quad(stage, "/World/Floor")
    dome = UsdLux.DomeLight_1.Define(stage, "/World/Sky")
    dome.CreateColorAttr(Gf.Vec3f(0.2, 0.3, 0.4))
    scene = save_and_load(stage, path)
    env = scene.environment
    assert env.texture == -1
    np.testing.assert_allclose(env.color, (0.2, 0.3, 0.4), rtol=1e-6)
    # poleAxis "scene" on a Z-up stage: +Z is the pole, (lat 0, lon 0) is -Y.
    np.testing.assert_allclose(env.world_to_light @ np.array([0.0, 0.0, 1.0]), (0, 1, 0), atol=1e-6)
    np.testing.assert_allclose(env.world_to_light @ np.array([0.0, -1.0, 0.0]), (0, 0, 1), atol=1e-6)


def test_lights_under_invisible_parent_are_skipped(tmp_path):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Floor")
    UsdGeom.Xform.Define(stage, "/World/Off").MakeInvisible()
    UsdLux.SphereLight.Define(stage, "/World/Off/Lamp")
    UsdLux.SphereLight.Define(stage, "/World/Lamp")
    scene = save_and_load(stage, path)
    assert [li.name for li in scene.lights] == ["/World/Lamp"]
