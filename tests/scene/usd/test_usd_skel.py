"""UsdSkel skinning: meshes bound to an animated Skeleton are drawn with pxr's skinned points."""

from __future__ import annotations

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt
from usd_stage_kit import add_mesh, mesh_world_points, new_stage

from warp_hybrid.scene.usd.loader import UsdSceneSource, load_scene
from warp_hybrid.scene.usd.subdivision import Sharpness, refine

XS = np.arange(5.0)  # a strip of four quads along x, bent at the joint x = 2
STRIP = [(x, y, 0.0) for x in XS for y in (-0.5, 0.5)]
STRIP_FACES = [v for i in range(4) for v in (2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1)]
TIP_WEIGHT = np.clip(np.repeat(XS, 2) - 1.0, 0.0, 1.0)  # x <= 1: the root only, x >= 3: the tip only
JOINTS = ["root", "root/tip"]
BENDS = {0.0: 0.0, 5.0: 40.0, 10.0: 90.0}  # time -> tip rotation about +Y (degrees)


def _translate(x: float) -> Gf.Matrix4d:
    return Gf.Matrix4d().SetTranslate(Gf.Vec3d(x, 0, 0))


def _rig(stage: Usd.Stage, animated: bool = True, rest_bend: float = 0.0, subdivision: str = "none") -> UsdGeom.Mesh:
    """A SkelRoot (moved), a Skeleton (turned) with two joints, the strip bound to them.
    The mesh's own transform is authored too: UsdSkel ignores it."""
    root = UsdSkel.Root.Define(stage, "/World/Rig")
    root.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    skel = UsdSkel.Skeleton.Define(stage, "/World/Rig/Skel")
    skel.AddRotateYOp().Set(30.0)
    skel.CreateJointsAttr(JOINTS)
    skel.CreateBindTransformsAttr(Vt.Matrix4dArray([Gf.Matrix4d(1), _translate(2)]))
    tip_rest = Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(0, 1, 0), rest_bend)) * _translate(2)
    skel.CreateRestTransformsAttr(Vt.Matrix4dArray([Gf.Matrix4d(1), tip_rest]))
    if animated:
        anim = UsdSkel.Animation.Define(stage, "/World/Rig/Skel/Anim")
        anim.CreateJointsAttr(JOINTS)
        anim.CreateTranslationsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(2, 0, 0)]))
        anim.CreateScalesAttr(Vt.Vec3hArray([Gf.Vec3h(1, 1, 1)] * 2))
        rotations = anim.CreateRotationsAttr()
        for t, degrees in BENDS.items():
            q = Gf.Rotation(Gf.Vec3d(0, 1, 0), degrees).GetQuat()
            rotations.Set(Vt.QuatfArray([Gf.Quatf(1), Gf.Quatf(q)]), t)
        UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    mesh = add_mesh(stage, "/World/Rig/Strip", STRIP, [4] * 4, STRIP_FACES, subdivision=subdivision)
    mesh.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    binding.CreateJointIndicesPrimvar(False, 2).Set(Vt.IntArray([j for _ in TIP_WEIGHT for j in (0, 1)]))
    binding.CreateJointWeightsPrimvar(False, 2).Set(Vt.FloatArray([w for t in TIP_WEIGHT for w in (1 - t, t)]))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1))
    return mesh


def _baked_world_points(stage: Usd.Stage, time: float) -> np.ndarray:
    """pxr's own skinning: UsdSkel.BakeSkinning on a copy of the stage, in world space."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    layer.TransferContent(stage.GetRootLayer())
    copy = Usd.Stage.Open(layer)
    assert UsdSkel.BakeSkinning(UsdSkel.Root(copy.GetPrimAtPath("/World/Rig")), Gf.Interval(0, 10))
    mesh = UsdGeom.Mesh(copy.GetPrimAtPath("/World/Rig/Strip"))
    local = np.asarray(mesh.GetPointsAttr().Get(time), dtype=np.float64)
    m = np.array(mesh.ComputeLocalToWorldTransform(time), dtype=np.float64)
    return local @ m[:3, :3] + m[3, :3]


def _rest_world_points(stage: Usd.Stage) -> np.ndarray:
    m = np.array(UsdGeom.Mesh(stage.GetPrimAtPath("/World/Rig/Strip")).ComputeLocalToWorldTransform(0))
    return np.array(STRIP) @ m[:3, :3] + m[3, :3]


def test_skinned_points_match_pxr_at_every_time_sample(tmp_path):
    stage, path = new_stage(tmp_path)
    _rig(stage)
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    rest = _rest_world_points(stage)
    first = source.scene_at(5.0)
    assert first.meshes[0].animated
    assert not [w for w in first.warnings if "Strip" in w]
    for time in (5.0, 10.0):  # the second time takes the fast path (only the skinned mesh re-read)
        scene = first if time == 5.0 else source.scene_at(time)
        points = mesh_world_points(scene, "/World/Rig/Strip")
        np.testing.assert_allclose(points, _baked_world_points(stage, time), atol=1e-5)
        assert np.linalg.norm(points - rest, axis=1).max() > 0.5  # not the rest pose
        np.testing.assert_array_equal(scene.points, load_scene(path, time).points)
    assert not np.allclose(mesh_world_points(first, "/World/Rig/Strip"), points)


def test_skinned_normals_are_computed_from_the_skinned_points(tmp_path):
    stage, path = new_stage(tmp_path)
    _rig(stage)
    stage.GetRootLayer().Save()
    scene = load_scene(path, 10.0)
    y_axis = Gf.Vec3d(0, 1, 0)  # the end of the strip (x = 4) turns rigidly with the tip joint, about +Y
    points = mesh_world_points(scene, "/World/Rig/Strip")
    at_end = np.isin(scene.indices, [8, 9])  # the points at x = 4
    expected = Gf.Rotation(y_axis, 30.0 + BENDS[10.0]).TransformDir(Gf.Vec3d(0, 0, 1))
    np.testing.assert_allclose(scene.corner_normals[at_end], np.broadcast_to(expected, (at_end.sum(), 3)), atol=1e-5)
    assert np.linalg.norm(points[8] - points[9]) > 0.99  # the strip keeps its width


def test_unanimated_skeleton_skins_to_its_rest_transforms(tmp_path):
    stage, path = new_stage(tmp_path)
    _rig(stage, animated=False, rest_bend=90.0)
    stage.GetRootLayer().Save()
    scene = load_scene(path)
    assert not scene.meshes[0].animated
    np.testing.assert_allclose(mesh_world_points(scene, "/World/Rig/Strip"), _baked_world_points(stage, 0), atol=1e-5)
    assert np.linalg.norm(mesh_world_points(scene, "/World/Rig/Strip") - _rest_world_points(stage), axis=1).max() > 1


def test_skinned_subdivision_mesh_refines_the_skinned_points(tmp_path):
    stage, path = new_stage(tmp_path)
    _rig(stage, subdivision="catmullClark")
    stage.GetRootLayer().Save()
    scene = load_scene(path, 10.0, subdivision_levels=1)
    r = refine("catmullClark", np.full(4, 4), np.array(STRIP_FACES), len(STRIP), Sharpness.smooth(), 1)
    expected = r.vertex_values(_baked_world_points(stage, 10.0))  # refinement commutes with placement
    np.testing.assert_allclose(mesh_world_points(scene, "/World/Rig/Strip"), expected, atol=1e-5)


def test_bad_bindings_are_reported_and_drawn_in_the_rest_pose(tmp_path):
    stage, path = new_stage(tmp_path)
    mesh = _rig(stage)
    UsdSkel.BindingAPI(mesh).GetJointWeightsPrimvar().Set(Vt.FloatArray([1.0, 0.0]))  # too few for 10 points
    loose = add_mesh(stage, "/World/Loose", STRIP, [4] * 4, STRIP_FACES)  # bound, but under no SkelRoot
    UsdSkel.BindingAPI.Apply(loose.GetPrim()).CreateSkeletonRel().SetTargets(["/World/Rig/Skel"])
    stage.GetRootLayer().Save()
    scene = load_scene(path, 10.0)
    assert any(w.startswith("/World/Rig/Strip: skinning (SkelBindingAPI) is not applied") for w in scene.warnings)
    assert (
        "/World/Loose: skinning (SkelBindingAPI) is not applied: the mesh is not under a SkelRoot; "
        "rendered in its rest pose"
    ) in scene.warnings
    np.testing.assert_allclose(mesh_world_points(scene, "/World/Rig/Strip"), _rest_world_points(stage), atol=1e-6)
    np.testing.assert_allclose(mesh_world_points(scene, "/World/Loose"), STRIP, atol=1e-6)


def test_instanced_rigs_skin_in_their_own_place(tmp_path):
    asset, asset_path = new_stage(tmp_path, "rig.usda")
    _rig(asset)
    asset.GetRootLayer().Save()
    stage, path = new_stage(tmp_path)
    for i, x in enumerate((0.0, 10.0)):  # two instances of the rig, the second moved along x
        instance = UsdGeom.Xform.Define(stage, f"/World/I{i}")
        instance.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        instance.GetPrim().GetReferences().AddReference(f"./{asset_path.name}")
        instance.GetPrim().SetInstanceable(True)
    stage.GetRootLayer().Save()
    scene = load_scene(path, 10.0)
    baked = _baked_world_points(asset, 10.0)
    np.testing.assert_allclose(mesh_world_points(scene, "/World/I0/Rig/Strip"), baked, atol=1e-5)
    np.testing.assert_allclose(mesh_world_points(scene, "/World/I1/Rig/Strip"), baked + (10, 0, 0), atol=1e-5)
