"""``model:drawMode``: a model whose draw mode applies is drawn as the solid box of its
bounds in its drawModeColor (bounds, cards) or not at all (origin) instead of its
subtree, with one warning per prim; elsewhere the full geometry is drawn as before."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Kind, Usd, UsdGeom
from usd_stage_kit import (
    bind,
    draw_mode_model,
    mesh_world_points,
    new_stage,
    preview_material,
    save_and_load,
    unit_quad,
)

from warp_hybrid.scene.usd.implicit import RINGS, SEGMENTS
from warp_hybrid.scene.usd.loader import UsdSceneSource

MODEL = "/World/Model"
BALL = f"{MODEL}/Ball"
SPHERE_TRIANGLES = 2 * SEGMENTS * (RINGS - 1)
RADIUS, BALL_AT, MODEL_AT = 2.0, (1.0, 0.0, 0.0), (0.0, 5.0, 0.0)
# The sphere's extent in the model's space, and in the world.
LOCAL_LO, LOCAL_HI = np.array(BALL_AT) - RADIUS, np.array(BALL_AT) + RADIUS
WORLD_LO, WORLD_HI = LOCAL_LO + MODEL_AT, LOCAL_HI + MODEL_AT
ORANGE = (0.9, 0.5, 0.1)
_WARNINGS = {
    "bounds": "model:drawMode bounds: drawn as a solid box of its bounds in model:drawModeColor "
    "(usdview draws the box's edges)",
    "cards": "model:drawMode cards: drawn as a solid box of its bounds in model:drawModeColor "
    "(cards and their textures model:cardTexture* are not supported)",
    "origin": "model:drawMode origin: nothing of it is drawn "
    "(usdview draws its axes as three lines; lines are not supported)",
}


def _warning(prim: str, mode: str) -> str:
    return f"{prim}: {_WARNINGS[mode]}"


BOUNDS_WARNING = _warning(MODEL, "bounds")


def _stage(tmp_path, mode="bounds", apply=True, kind=Kind.Tokens.assembly, color=ORANGE):
    """/World (a group) / Model (``mode``, ``apply``, ``kind``, at MODEL_AT) / Ball (a
    sphere of RADIUS at BALL_AT)."""
    stage, path = new_stage(tmp_path)
    Usd.ModelAPI(stage.GetPrimAtPath("/World")).SetKind(Kind.Tokens.group)
    model = draw_mode_model(stage, MODEL, mode, apply=apply, kind=kind, color=color)
    model.AddTranslateOp().Set(Gf.Vec3d(*MODEL_AT))
    ball = UsdGeom.Sphere.Define(stage, BALL)
    ball.CreateRadiusAttr(RADIUS)
    ball.AddTranslateOp().Set(Gf.Vec3d(*BALL_AT))
    return stage, path


def _range(scene, prim_path):
    return next(m for m in scene.meshes if m.prim_path == prim_path)


def _drawn(scene) -> list[tuple[str, int]]:
    return [(m.prim_path, m.triangle_count) for m in scene.meshes]


def _draw_mode_warnings(scene) -> list[str]:
    return [w for w in scene.warnings if "drawMode" in w]


def _assert_box(scene, lo, hi, color=ORANGE):
    """The model is drawn as one closed box from ``lo`` to ``hi`` with albedo ``color``."""
    assert _drawn(scene) == [(MODEL, 12)]
    points = mesh_world_points(scene, MODEL)
    np.testing.assert_allclose(points.min(axis=0), lo, atol=1e-6)
    np.testing.assert_allclose(points.max(axis=0), hi, atol=1e-6)
    r = _range(scene, MODEL)
    tris = scene.points[scene.indices[r.first_triangle : r.first_triangle + 12]].astype(np.float64)
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    outward = np.einsum("ti,ti->t", n, tris.mean(axis=1) - 0.5 * (points.min(axis=0) + points.max(axis=0)))
    assert (outward > 0).all()  # counter-clockwise seen from outside
    d = np.asarray(hi) - np.asarray(lo)
    area = 2 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    assert abs(np.linalg.norm(n, axis=1).sum() / 2 - area) < 1e-4
    materials = {int(i) for i in scene.triangle_material[r.first_triangle : r.first_triangle + 12]}
    assert len(materials) == 1
    np.testing.assert_allclose(scene.materials[materials.pop()].diffuse, color, rtol=1e-6)


def test_bounds_with_apply_draw_mode_is_the_box_of_the_extent(tmp_path):
    stage, path = _stage(tmp_path)
    scene = save_and_load(stage, path)
    _assert_box(scene, WORLD_LO, WORLD_HI)
    assert _draw_mode_warnings(scene) == [BOUNDS_WARNING]


def test_without_apply_draw_mode_the_geometry_is_drawn(tmp_path):
    stage, path = _stage(tmp_path, apply=None)  # an assembly: applyDrawMode falls back to false
    scene = save_and_load(stage, path)
    assert _drawn(scene) == [(BALL, SPHERE_TRIANGLES)]
    assert _draw_mode_warnings(scene) == []


def test_a_component_applies_its_draw_mode_unless_apply_draw_mode_says_no(tmp_path):
    stage, path = _stage(tmp_path, apply=None, kind=Kind.Tokens.component)
    _assert_box(save_and_load(stage, path), WORLD_LO, WORLD_HI)
    stage, path = _stage(tmp_path / "off", apply=False, kind=Kind.Tokens.component)
    assert _drawn(save_and_load(stage, path)) == [(BALL, SPHERE_TRIANGLES)]


def test_draw_mode_is_read_on_models_only(tmp_path):
    stage, path = _stage(tmp_path, kind=None)  # no kind: not a model, so pxr resolves default
    scene = save_and_load(stage, path)
    assert _drawn(scene) == [(BALL, SPHERE_TRIANGLES)]
    assert _draw_mode_warnings(scene) == []


def test_default_draws_the_geometry(tmp_path):
    stage, path = _stage(tmp_path, mode="default")
    assert _drawn(save_and_load(stage, path)) == [(BALL, SPHERE_TRIANGLES)]


def test_the_draw_mode_colour_falls_back_to_grey(tmp_path):
    stage, path = _stage(tmp_path, color=None)
    _assert_box(save_and_load(stage, path), WORLD_LO, WORLD_HI, color=(0.18, 0.18, 0.18))


def test_the_box_ignores_the_bound_material(tmp_path):
    stage, path = _stage(tmp_path)
    mat, _shader = preview_material(stage, "/World/Looks/Red", diffuseColor=(1.0, 0.0, 0.0))
    bind(stage.GetPrimAtPath(MODEL), mat)
    _assert_box(save_and_load(stage, path), WORLD_LO, WORLD_HI)


def test_origin_draws_nothing_of_the_subtree(tmp_path):
    stage, path = _stage(tmp_path, mode="origin")
    unit_quad(stage, "/World/Floor")
    scene = save_and_load(stage, path)
    assert _drawn(scene) == [("/World/Floor", 2)]
    assert _draw_mode_warnings(scene) == [_warning(MODEL, "origin")]


def test_cards_are_the_box_with_a_warning(tmp_path):
    stage, path = _stage(tmp_path, mode="cards")
    scene = save_and_load(stage, path)
    _assert_box(scene, WORLD_LO, WORLD_HI)
    assert _draw_mode_warnings(scene) == [_warning(MODEL, "cards")]


@pytest.mark.parametrize("parent_mode", ["bounds", "origin"])
def test_inherited_follows_the_parent_model(tmp_path, parent_mode):
    stage, path = new_stage(tmp_path)
    Usd.ModelAPI(stage.GetPrimAtPath("/World")).SetKind(Kind.Tokens.group)
    draw_mode_model(stage, "/World/Set", parent_mode, kind=Kind.Tokens.assembly)  # not applied itself
    for name, mode in (("Inherits", None), ("Explicit", "inherited"), ("Default", "default")):
        draw_mode_model(stage, f"/World/Set/{name}", mode, apply=True, kind=Kind.Tokens.assembly)
        unit_quad(stage, f"/World/Set/{name}/Q", size=2.0)
    scene = save_and_load(stage, path)
    boxes = [("/World/Set/Inherits", 12), ("/World/Set/Explicit", 12)] if parent_mode == "bounds" else []
    assert sorted(_drawn(scene)) == sorted([*boxes, ("/World/Set/Default/Q", 2)])
    for prim, _count in boxes:  # the box of a flat quad is flat too
        p = mesh_world_points(scene, prim)
        np.testing.assert_allclose([p.min(axis=0), p.max(axis=0)], [(0, 0, 0), (2, 2, 0)], atol=1e-6)
    assert _draw_mode_warnings(scene) == [
        _warning(f"/World/Set/{name}", parent_mode) for name in ("Inherits", "Explicit")
    ]


def test_the_box_follows_an_animated_transform_and_an_animated_subtree(tmp_path):
    stage, path = _stage(tmp_path)
    op = stage.GetPrimAtPath(MODEL).GetAttribute("xformOp:translate")
    op.Set(Gf.Vec3d(*MODEL_AT), 0.0)
    op.Set(Gf.Vec3d(0.0, 9.0, 0.0), 8.0)
    radius = UsdGeom.Sphere.Get(stage, BALL).GetRadiusAttr()
    radius.Set(RADIUS, 0.0)
    radius.Set(2 * RADIUS, 8.0)
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    first = source.scene_at(0.0)
    _assert_box(first, WORLD_LO, WORLD_HI)
    assert _range(first, MODEL).animated
    last = source.scene_at(8.0)
    _assert_box(last, np.array(BALL_AT) - 2 * RADIUS + (0, 9, 0), np.array(BALL_AT) + 2 * RADIUS + (0, 9, 0))
    mid = source.scene_at(4.0)
    _assert_box(mid, np.array(BALL_AT) - 1.5 * RADIUS + (0, 7, 0), np.array(BALL_AT) + 1.5 * RADIUS + (0, 7, 0))
    assert source.warnings.count(BOUNDS_WARNING) == 1


def test_a_static_box_is_shared_across_time_codes(tmp_path):
    stage, path = _stage(tmp_path)
    op = UsdGeom.Xform.Define(stage, "/World/Mover").AddTranslateOp()
    op.Set(Gf.Vec3d(0, 0, 0), 0.0)
    op.Set(Gf.Vec3d(0, 4, 0), 8.0)
    unit_quad(stage, "/World/Mover/Q")
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    first, later = source.scene_at(0.0), source.scene_at(8.0)
    assert not _range(first, MODEL).animated
    np.testing.assert_array_equal(mesh_world_points(first, MODEL), mesh_world_points(later, MODEL))
    assert source.warnings.count(BOUNDS_WARNING) == 1


def test_models_in_point_instancer_prototypes_are_boxes(tmp_path):
    stage, path = new_stage(tmp_path)
    Usd.ModelAPI(stage.GetPrimAtPath("/World")).SetKind(Kind.Tokens.group)
    instancer = UsdGeom.PointInstancer.Define(stage, "/World/Crowd")
    proto = draw_mode_model(stage, "/World/Crowd/Protos/Model", "bounds", apply=True, kind=Kind.Tokens.assembly)
    UsdGeom.Sphere.Define(stage, "/World/Crowd/Protos/Model/Ball").CreateRadiusAttr(0.5)
    for group in ("/World/Crowd", "/World/Crowd/Protos"):  # a model hierarchy down to the model
        Usd.ModelAPI(stage.GetPrimAtPath(group)).SetKind(Kind.Tokens.group)
    instancer.CreatePrototypesRel().SetTargets([proto.GetPath()])
    instancer.CreateProtoIndicesAttr([0, 0])
    instancer.CreatePositionsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(3, 0, 0)])
    scene = save_and_load(stage, path)
    names = ["/World/Crowd/Protos/Model@/World/Crowd[0]", "/World/Crowd/Protos/Model@/World/Crowd[1]"]
    assert _drawn(scene) == [(names[0], 12), (names[1], 12)]
    for name, x in zip(names, (0.0, 3.0)):
        p = mesh_world_points(scene, name)
        np.testing.assert_allclose([p.min(axis=0), p.max(axis=0)], [(x - 0.5, -0.5, -0.5), (x + 0.5, 0.5, 0.5)])
    assert _draw_mode_warnings(scene) == [_warning("/World/Crowd/Protos/Model", "bounds")]


def test_a_model_with_nothing_to_bound_draws_nothing(tmp_path):
    stage, path = new_stage(tmp_path)
    Usd.ModelAPI(stage.GetPrimAtPath("/World")).SetKind(Kind.Tokens.group)
    draw_mode_model(stage, MODEL, "bounds", apply=True, kind=Kind.Tokens.assembly)
    unit_quad(stage, "/World/Floor")
    scene = save_and_load(stage, path)
    assert sorted(_drawn(scene)) == [("/World/Floor", 2), (MODEL, 0)]
    assert f"{MODEL}: the mesh has no faces: nothing of it is drawn" in scene.warnings


def test_an_unknown_draw_mode_draws_the_geometry(tmp_path):
    stage, path = _stage(tmp_path, mode="boxes")
    scene = save_and_load(stage, path)
    assert _drawn(scene) == [(BALL, SPHERE_TRIANGLES)]
    assert _draw_mode_warnings(scene) == [
        f"{MODEL}: model:drawMode 'boxes' is not a USD draw mode; drawn as its full geometry"
    ]
