"""Stage metadata and fragile input: upAxis X or invalid warns, time rates that are not
positive are refused, a malformed mesh is skipped with a warning (strict: refused)."""

from __future__ import annotations

import pytest
from usd_stage_kit import add_mesh, new_stage, save_and_load, unit_quad

from warp_hybrid.errors import SceneError
from warp_hybrid.scene.usd.loader import load_scene


@pytest.mark.parametrize("axis, words", [("X", "X, which UsdGeom does not allow"), ("Q", "'Q', not a valid value")])
def test_unsupported_up_axis_warns_and_reads_as_y(tmp_path, axis, words):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Q")
    stage.SetMetadata("upAxis", axis)
    scene = save_and_load(stage, path)
    assert scene.up_axis == "Y"
    assert [w for w in scene.warnings if w.startswith("upAxis")] == [f"upAxis is {words} (only Y or Z); treated as Y"]


def test_z_up_is_kept_without_a_warning(tmp_path):
    stage, path = new_stage(tmp_path, up_axis="Z")
    unit_quad(stage, "/World/Q")
    scene = save_and_load(stage, path)
    assert scene.up_axis == "Z" and not [w for w in scene.warnings if "upAxis" in w]


@pytest.mark.parametrize("name, value", [("timeCodesPerSecond", 0.0), ("framesPerSecond", -24.0)])
def test_time_rates_must_be_positive(tmp_path, name, value):
    stage, path = new_stage(tmp_path, name="scene.usdc")
    unit_quad(stage, "/World/Q")
    getattr(stage, f"Set{name[0].upper()}{name[1:]}")(value)
    stage.GetRootLayer().Save()
    with pytest.raises(SceneError, match=f"{name} is {value:g}; it must be a positive number") as err:
        load_scene(path)
    assert str(err.value).startswith(str(path))


def test_text_layer_with_zero_fps_fails_with_pxrs_reason(tmp_path):
    path = tmp_path / "zero.usda"
    path.write_text('#usda 1.0\n(\n    framesPerSecond = 0\n)\ndef Xform "World" {}\n')
    with pytest.raises(SceneError, match='invalid value for field "framesPerSecond"'):
        load_scene(path)


def test_malformed_mesh_is_skipped_with_a_warning_naming_it(tmp_path):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Good")
    add_mesh(stage, "/World/Broken", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 7])
    scene = save_and_load(stage, path)
    assert scene.triangle_count == 2
    broken = [w for w in scene.warnings if w.startswith("/World/Broken:")]
    assert broken == [
        "/World/Broken: malformed mesh skipped, nothing of it is drawn: "
        "faceVertexIndices holds 7, outside the 3 points (valid 0..2)"
    ]
    with pytest.raises(SceneError, match="/World/Broken: faceVertexIndices holds 7"):
        load_scene(path, strict=True)
