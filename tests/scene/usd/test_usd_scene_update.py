"""``UsdSceneSource.scene_at`` at later times: the fast path re-evaluates only what may
vary and must give exactly what a full evaluation (a fresh source at that time) gives."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, UsdGeom, UsdLux
from usd_stage_kit import add_mesh, new_stage, static_and_moving_quads, unit_quad

from warp_hybrid.errors import SceneError
from warp_hybrid.scene.model import Scene
from warp_hybrid.scene.usd.loader import UsdSceneSource

SCENES = Path(__file__).resolve().parents[3] / "scenes"
GEOMETRY = ("points", "indices", "corner_normals", "corner_uvs", "triangle_material")


def assert_same_scene(fast: Scene, full: Scene) -> None:
    """Bit-for-bit the same arrays and equal lights, cameras, dome, materials, textures."""
    for name in GEOMETRY:
        a, b = getattr(fast, name), getattr(full, name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        assert np.array_equal(a.view(np.int32), b.view(np.int32)), name  # bits: -0.0 differs from 0.0
    assert fast.meshes == full.meshes
    assert fast.lights == full.lights
    assert fast.materials == full.materials
    assert fast.textures == full.textures
    assert [i.path for i in fast.images] == [i.path for i in full.images]
    assert all(np.array_equal(a.pixels, b.pixels) for a, b in zip(fast.images, full.images))
    assert (fast.environment is None) == (full.environment is None)
    if fast.environment is not None:
        a, b = fast.environment, full.environment
        assert (a.name, a.color, a.texture) == (b.name, b.color, b.texture)
        assert np.array_equal(a.world_to_light, b.world_to_light)
    assert len(fast.cameras) == len(full.cameras)
    for a, b in zip(fast.cameras, full.cameras):
        assert (a.name, a.focal_length, a.horizontal_aperture, a.near, a.far) == (
            b.name,
            b.focal_length,
            b.horizontal_aperture,
            b.near,
            b.far,
        )
        assert np.array_equal(a.cam_to_world, b.cam_to_world)
    assert fast.time == full.time


def check_times(path: Path, times: list[float]) -> list[Scene]:
    """Evaluate ``path`` at ``times`` on one source and compare each with a fresh source."""
    source = UsdSceneSource(path)
    scenes = []
    for t in times:
        scene = source.scene_at(t)
        assert_same_scene(scene, UsdSceneSource(path).scene_at(t))
        assert not any(getattr(scene, n).flags.writeable for n in GEOMETRY)
        scenes.append(scene)
    return scenes


def test_textured_animated_matches_full_evaluation_forwards_backwards_and_repeated():
    times = [0.0, 12.0, 12.5, 48.0, 3.0, 3.0, 0.0, 30.25]
    scenes = check_times(SCENES / "textured_animated.usda", times)
    a, b, repeat = scenes[3], scenes[4], scenes[5]
    assert b.points is not a.points  # the cube moved: a fresh copy
    assert b.indices is a.indices and b.corner_uvs is a.corner_uvs and b.triangle_material is a.triangle_material
    assert all(getattr(repeat, n) is getattr(b, n) for n in GEOMETRY)  # same time again: nothing changed


def test_shared_animated_layers_match_full_evaluation(shared_scenes):
    entries = [e for e in json.loads((shared_scenes / "manifest.json").read_text())["scenes"] if e.get("animated")]
    assert entries
    for entry in entries:
        path = shared_scenes / entry["file"]
        start, end = UsdSceneSource(path).time_range
        span = end - start
        times = [start, start + 0.5 * span, start + 0.5 * span + 0.3, end, start + 0.1 * span, start + 0.1 * span]
        scenes = check_times(path, times)
        static = np.ones(len(scenes[0].points), dtype=bool)
        for r in scenes[0].meshes:
            if r.animated:
                static[r.first_point : r.first_point + r.point_count] = False
        assert static.any() and not static.all(), entry["name"]
        np.testing.assert_array_equal(scenes[1].points[static], scenes[0].points[static])


def test_static_stage_returns_the_very_same_arrays():
    source = UsdSceneSource(SCENES / "cornell_glass.usda")
    a = source.scene_at(0.0)
    b, c = source.scene_at(5.0), source.scene_at(0.0)
    for scene in (b, c):
        assert all(getattr(scene, n) is getattr(a, n) for n in GEOMETRY)
        assert all(getattr(scene, n) is getattr(a, n) for n in ("lights", "cameras", "materials", "meshes"))
    assert (a.time, b.time, c.time) == (0.0, 5.0, 0.0)
    assert_same_scene(b, UsdSceneSource(SCENES / "cornell_glass.usda").scene_at(5.0))


def test_moved_arrays_are_fresh_copies_and_earlier_scenes_keep_their_content(tmp_path):
    stage, path = static_and_moving_quads(tmp_path)
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    a = source.scene_at(0.0)
    before = a.points.copy()
    b = source.scene_at(4.0)
    np.testing.assert_array_equal(a.points, before)
    assert b.points is not a.points and b.corner_normals is a.corner_normals  # translation: normals unchanged
    static, moved = b.meshes
    np.testing.assert_array_equal(b.points[: static.point_count], a.points[: static.point_count])
    np.testing.assert_allclose(b.points[moved.first_point :, 1] - a.points[moved.first_point :, 1], 2.0)
    with pytest.raises(ValueError):
        b.points[0, 0] = 1.0


def _animated_stage(tmp_path: Path) -> Path:
    """Lights, cameras, instancers, a mirroring transform and a deforming mesh, animated."""
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Floor", size=4.0)
    flip = UsdGeom.Xform.Define(stage, "/World/Flip")
    scale = flip.AddScaleOp()
    scale.Set(Gf.Vec3f(1, 1, 1), 0.0)
    scale.Set(Gf.Vec3f(-1, 1, 1), 10.0)  # crosses a mirror: winding and uvs flip
    add_mesh(stage, "/World/Flip/M", [(0, 0, 1), (1, 0, 1), (0, 1, 1)], [3], [0, 1, 2])
    wobble = add_mesh(stage, "/World/Wobble", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4], [0, 1, 2, 3])
    wobble.GetPointsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0), Gf.Vec3f(1, 1, 0), Gf.Vec3f(0, 1, 0)], 0.0)
    wobble.GetPointsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(3, 0, 0), Gf.Vec3f(1, 1, 2), Gf.Vec3f(0, 1, 0)], 10.0)
    sphere = UsdLux.SphereLight.Define(stage, "/World/Bulb")
    sphere.CreateIntensityAttr().Set(1.0, 0.0)
    sphere.GetIntensityAttr().Set(5.0, 10.0)
    UsdLux.DistantLight.Define(stage, "/World/Sun")
    cam = UsdGeom.Camera.Define(stage, "/World/Cam")
    cam.CreateFocalLengthAttr().Set(20.0, 0.0)
    cam.GetFocalLengthAttr().Set(80.0, 10.0)
    UsdGeom.Camera.Define(stage, "/World/Still").AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    tri = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    moving = UsdGeom.PointInstancer.Define(stage, "/World/Moving")
    UsdGeom.Xform.Define(stage, "/World/Moving/Protos/P")
    add_mesh(stage, "/World/Moving/Protos/P/M", tri, [3], [0, 1, 2])
    moving.CreatePrototypesRel().SetTargets(["/World/Moving/Protos/P"])
    moving.CreateProtoIndicesAttr([0, 0])
    moving.CreatePositionsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(2, 0, 0)], 0.0)
    moving.GetPositionsAttr().Set([Gf.Vec3f(0, 5, 0), Gf.Vec3f(2, 5, 3)], 10.0)
    spun = UsdGeom.PointInstancer.Define(stage, "/World/Spun")  # still instances, animated prototype root
    root = UsdGeom.Xform.Define(stage, "/World/Spun/Protos/P")
    rot = root.AddRotateZOp()
    rot.Set(0.0, 0.0)
    rot.Set(90.0, 10.0)
    add_mesh(stage, "/World/Spun/Protos/P/M", tri, [3], [0, 1, 2])
    spun.CreatePrototypesRel().SetTargets(["/World/Spun/Protos/P"])
    spun.CreateProtoIndicesAttr([0])
    spun.CreatePositionsAttr([Gf.Vec3f(-3, 0, 0)])
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(10)
    stage.GetRootLayer().Save()
    return path


def test_animated_lights_cameras_instancers_and_mirroring_match_full_evaluation(tmp_path):
    path = _animated_stage(tmp_path)
    scenes = check_times(path, [0.0, 2.5, 7.0, 10.0, 2.5, 0.0])
    a, b = scenes[0], scenes[1]
    assert [m.prim_path for m in a.meshes if m.animated] == [
        "/World/Flip/M",
        "/World/Wobble",
        "/World/Moving/Protos/P/M@/World/Moving[0]",
        "/World/Moving/Protos/P/M@/World/Moving[1]",
        "/World/Spun/Protos/P/M@/World/Spun[0]",  # the prototype root's own transform is animated
    ]
    assert scenes[3].indices is not a.indices  # the mirrored mesh's winding flipped
    assert b.lights[0].color != a.lights[0].color and b.lights[1] == a.lights[1]
    assert b.cameras[0].focal_length != a.cameras[0].focal_length
    assert b.cameras[1] is a.cameras[1]  # a still camera is not read again


def test_visibility_and_topology_changes_fall_back_to_full_evaluation(tmp_path):
    stage, path = new_stage(tmp_path)
    UsdGeom.Camera.Define(stage, "/World/Cam")  # a fresh source would frame its own first time
    unit_quad(stage, "/World/Floor")
    group = UsdGeom.Xform.Define(stage, "/World/Blink")
    group.CreateVisibilityAttr().Set(UsdGeom.Tokens.inherited, 0.0)
    group.GetVisibilityAttr().Set(UsdGeom.Tokens.invisible, 5.0)
    unit_quad(stage, "/World/Blink/Q", z=1.0)
    grow = add_mesh(stage, "/World/Grow", [(0, 0, 2), (1, 0, 2), (1, 1, 2), (0, 1, 2)], [3], [0, 1, 2])
    grow.GetFaceVertexCountsAttr().Set([3], 0.0)
    grow.GetFaceVertexCountsAttr().Set([4], 3.0)
    grow.GetFaceVertexIndicesAttr().Set([0, 1, 2], 0.0)
    grow.GetFaceVertexIndicesAttr().Set([0, 1, 2, 3], 3.0)
    pi = UsdGeom.PointInstancer.Define(stage, "/World/PI")
    proto = UsdGeom.Xform.Define(stage, "/World/PI/Protos/P")
    add_mesh(stage, "/World/PI/Protos/P/M", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    proto.CreateVisibilityAttr().Set(UsdGeom.Tokens.inherited, 0.0)
    proto.GetVisibilityAttr().Set(UsdGeom.Tokens.invisible, 8.0)
    pi.CreatePrototypesRel().SetTargets([proto.GetPath()])
    pi.CreateProtoIndicesAttr().Set([0], 0.0)
    pi.GetProtoIndicesAttr().Set([0, 0, 0], 6.0)
    pi.CreatePositionsAttr().Set([Gf.Vec3f(5, 0, 0)], 0.0)
    pi.GetPositionsAttr().Set([Gf.Vec3f(5, 0, 0), Gf.Vec3f(6, 0, 0), Gf.Vec3f(7, 0, 0)], 6.0)
    stage.GetRootLayer().Save()
    scenes = check_times(path, [0.0, 1.0, 4.0, 5.0, 6.0, 9.0, 2.0, 0.0])
    assert [s.triangle_count for s in scenes] == [2 + 2 + 1 + 1, 6, 7, 5, 7, 4, 6, 6]


def test_an_error_at_a_later_time_names_the_file_and_prim(tmp_path):
    stage, path = new_stage(tmp_path)
    unit_quad(stage, "/World/Good")
    bad = add_mesh(stage, "/World/Bad", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    bad.GetPointsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0)], 0.0)
    bad.GetPointsAttr().Set([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, float("nan"), 0), Gf.Vec3f(0, 1, 0)], 2.0)
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    source.scene_at(0.0)
    with pytest.raises(SceneError) as fast:
        source.scene_at(2.0)
    with pytest.raises(SceneError) as full:
        UsdSceneSource(path).scene_at(2.0)
    assert str(fast.value) == str(full.value)
    assert str(path) in str(fast.value) and "/World/Bad" in str(fast.value)
    assert_same_scene(source.scene_at(0.0), UsdSceneSource(path).scene_at(0.0))  # still usable
