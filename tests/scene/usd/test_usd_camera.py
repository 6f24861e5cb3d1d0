"""UsdGeom.Camera reading, camera selection and the framing camera fallback."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, UsdGeom
from usd_stage_kit import add_mesh, new_stage, save_and_load, unit_quad

from warp_hybrid.errors import RenderSettingsError
from warp_hybrid.scene.usd.camera import FRAMING_CAMERA_NAME, select_camera


def _camera(stage, path, focal=35.0, h=20.955, v=15.2908, clip=(0.1, 500.0)):
    cam = UsdGeom.Camera.Define(stage, path)
    cam.CreateFocalLengthAttr(focal)
    cam.CreateHorizontalApertureAttr(h)
    cam.CreateVerticalApertureAttr(v)
    cam.CreateClippingRangeAttr(Gf.Vec2f(*clip))
    return cam


def test_camera_parameters_and_a_uniformly_scaled_transform(tmp_path):
    """The camera's frame drops the rig's scale; the clipping range scales with it, as
    ``Gf.Frustum.Transform`` defines it (the field of view does not change)."""
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Q")
    rig = UsdGeom.Xform.Define(stage, "/World/Rig")
    rig.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
    rig.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    cam = _camera(stage, "/World/Rig/Cam")
    cam.AddRotateYOp().Set(30.0)
    scene = save_and_load(stage, path)
    c = scene.cameras[0]
    assert c.name == "/World/Rig/Cam"
    assert (c.focal_length, c.horizontal_aperture, c.vertical_aperture) == pytest.approx((35.0, 20.955, 15.2908))
    assert (c.near, c.far) == pytest.approx((0.2, 1000.0))
    np.testing.assert_allclose(c.position, (1, 2, 3), atol=1e-9)
    a = math.radians(30.0)
    np.testing.assert_allclose(c.forward, (-math.sin(a), 0, -math.cos(a)), atol=1e-9)  # local -Z turned about Y
    np.testing.assert_allclose(c.cam_to_world[:3, :3].T @ c.cam_to_world[:3, :3], np.eye(3), atol=1e-9)
    np.testing.assert_allclose(c.cam_to_world[3], (0, 0, 0, 1))


def test_camera_selection_defaults_to_first_in_traversal_order(tmp_path):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Q")
    _camera(stage, "/World/B")
    _camera(stage, "/World/A", focal=50.0)
    hidden = UsdGeom.Xform.Define(stage, "/World/Off")
    hidden.MakeInvisible()
    _camera(stage, "/World/Off/C")  # cameras are listed even under invisible prims
    scene = save_and_load(stage, path)
    assert [c.name for c in scene.cameras] == ["/World/B", "/World/A", "/World/Off/C"]
    assert select_camera(scene.cameras).name == "/World/B"
    assert select_camera(scene.cameras, "/World/A").focal_length == pytest.approx(50.0)
    with pytest.raises(RenderSettingsError, match="/World/Nope.*/World/B, /World/A"):
        select_camera(scene.cameras, "/World/Nope")


@pytest.mark.parametrize("up_axis", ["Y", "Z"])
def test_framing_camera_sees_the_whole_scene(tmp_path, up_axis):
    stage, path = new_stage(tmp_path, up_axis=up_axis)
    add_mesh(stage, "/World/Box", [(-1, 0, 2), (3, 0, 2), (3, 2, 2), (-1, 2, 5)], [4], [0, 1, 2, 3])
    scene = save_and_load(stage, path)
    assert [c.name for c in scene.cameras] == [FRAMING_CAMERA_NAME]
    assert any("no UsdGeom.Camera" in w for w in scene.warnings)
    cam = scene.cameras[0]
    lo, hi = scene.bounds
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    local = (cam.world_to_cam @ np.c_[corners, np.ones(8)].T).T[:, :3]
    depth = -local[:, 2]
    assert (depth > cam.near).all() and (depth < cam.far).all()
    assert (np.abs(local[:, 0] / depth) <= cam.tan_half_fov_x).all()
    assert (np.abs(local[:, 1] / depth) <= cam.tan_half_fov_y(640, 480)).all()
    up = np.array([0, 0, 1.0]) if up_axis == "Z" else np.array([0, 1.0, 0])
    assert cam.cam_to_world[:3, 1] @ up > 0.9  # upright
    assert cam.forward @ up < 0  # looking slightly down
