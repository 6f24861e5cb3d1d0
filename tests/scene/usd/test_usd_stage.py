"""Stage metadata, bad files and bad geometry: clear SceneErrors naming file and prim."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom
from usd_stage_kit import add_mesh, new_stage, save_and_load, static_and_moving_quads, unit_quad

from warp_hybrid.errors import SceneError
from warp_hybrid.scene.open import open_scene_source
from warp_hybrid.scene.usd.loader import UsdSceneSource, load_scene


def test_meters_per_unit_up_axis_and_time_range(tmp_path):
    stage, path = new_stage(tmp_path, up_axis="Z", meters_per_unit=0.01)
    unit_quad(stage, "/World/Q")
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(50)
    stage.SetTimeCodesPerSecond(30)
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    scene = source.scene_at()
    assert (scene.meters_per_unit, scene.up_axis) == (0.01, "Z")
    assert source.time_range == scene.time_range == (1.0, 50.0)
    assert scene.time_codes_per_second == 30.0
    assert scene.time == 1.0  # default time: the start of the range


def test_static_stage_has_no_time_range(tmp_path):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Q")
    scene = save_and_load(stage, path)
    assert scene.time_range is None and scene.time == 0.0
    assert (scene.meters_per_unit, scene.up_axis) == (1.0, "Y")


def test_missing_file(tmp_path):
    missing = tmp_path / "nope.usda"
    with pytest.raises(SceneError, match="file not found") as err:
        load_scene(missing)
    assert str(missing) in str(err.value)


@pytest.mark.parametrize("name, data", [("text.usda", b"hello, not usd"), ("junk.usdc", b"\x00\x01garbage" * 20)])
def test_not_usd(tmp_path, name, data):
    bad = tmp_path / name
    bad.write_bytes(data)
    with pytest.raises(SceneError, match="not a readable USD file") as err:
        load_scene(bad)
    assert str(err.value).startswith(str(bad))


def test_unsupported_extension(tmp_path):
    f = tmp_path / "scene.fbx"
    f.write_text("x")
    with pytest.raises(SceneError, match="unsupported file type '.fbx'") as err:
        open_scene_source(f)
    assert str(f) in str(err.value)


def test_mesh_file_goes_through_conversion(tmp_path):
    obj = tmp_path / "quad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    scene = open_scene_source(obj).scene_at()
    assert scene.triangle_count == 2
    assert scene.path == str(obj)


def test_off_mesh_file_opens(tmp_path):
    off = tmp_path / "quad.off"
    off.write_text("OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
    assert open_scene_source(off).scene_at().triangle_count == 2


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_points(tmp_path, bad):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Good")
    add_mesh(stage, "/World/Bad", [(0, 0, 0), (1, bad, 0), (0, 1, 0)], [3], [0, 1, 2])
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError, match="point 1 is not finite") as err:
        load_scene(path)
    assert str(path) in str(err.value) and "/World/Bad" in str(err.value)


def test_non_finite_transform_names_the_prim(tmp_path):
    stage, path = new_stage(tmp_path)
    x = UsdGeom.Xform.Define(stage, "/World/X")
    x.AddTranslateOp().Set(Gf.Vec3d(float("nan"), 0, 0))
    unit_quad(stage, "/World/X/Q")
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError, match="not finite") as err:
        load_scene(path)
    assert str(path) in str(err.value) and "/World/X/Q" in str(err.value)


@pytest.mark.parametrize(
    "counts, indices, message",
    [
        ([3], [0, 1, 7], "faceVertexIndices holds 7, outside the 3 points"),
        ([3], [0, -1, 2], "faceVertexIndices holds -1"),
        ([3, 3], [0, 1, 2, 0], "faceVertexCounts sum to 6 but faceVertexIndices has 4 entries"),
        ([-3], [0, 1, 2], "negative count"),
    ],
)
def test_bad_topology(tmp_path, counts, indices, message):
    stage, path = new_stage(tmp_path)
    add_mesh(stage, "/World/Broken", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], counts, indices)
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError, match=message) as err:  # strict: the refusal (by default it is skipped)
        load_scene(path, strict=True)
    assert str(err.value).startswith(f"{path}: /World/Broken: ")


def test_missing_sublayer_is_a_warning(tmp_path):
    stage, path = new_stage(tmp_path)
    stage.GetRootLayer().subLayerPaths.append("gone.usda")
    unit_quad(stage, "/World/Q")
    scene = save_and_load(stage, path)
    assert scene.triangle_count == 2
    assert any("gone.usda" in w for w in scene.warnings)


def test_scene_at_reuses_static_data_and_updates_animated_points(tmp_path):
    stage, path = static_and_moving_quads(tmp_path)
    wobble = add_mesh(stage, "/World/Wobble", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    wobble.GetPointsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0)], 0.0)
    wobble.GetPointsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(3, 0, 0), Gf.Vec3f(0, 1, 0)], 8.0)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(8)
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    a, b = source.scene_at(0.0), source.scene_at(4.0)
    np.testing.assert_array_equal(a.indices, b.indices)
    assert [m.animated for m in a.meshes] == [False, True, True]
    moved = np.abs(a.points - b.points).max(axis=1) > 0
    static, mover_r, wobble_r = a.meshes
    assert not moved[static.first_point : static.first_point + static.point_count].any()
    np.testing.assert_allclose(
        b.points[mover_r.first_point : mover_r.first_point + 4, 1]
        - a.points[mover_r.first_point : mover_r.first_point + 4, 1],
        2.0,
    )
    np.testing.assert_allclose(b.points[wobble_r.first_point + 1], (2, 0, 0))
    assert (b.time, a.time) == (4.0, 0.0)


def test_usd_file_opened_twice_gives_equal_scenes(tmp_path):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Q")
    stage.GetRootLayer().Save()
    a = load_scene(path)
    b = UsdSceneSource(path, stage=Usd.Stage.Open(str(path))).scene_at()
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.corner_normals, b.corner_normals)
