"""UsdGeom.Mesh loading: triangulation, holes, orientation, normals and uvs."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, Vt
from usd_stage_kit import add_mesh, new_stage, save_and_load, triangle_areas, triangle_normals

from warp_hybrid.scene.usd.meshes import triangulate


def test_quads_and_ngons_triangulated_with_count_and_winding(tmp_path):
    stage, path = new_stage(tmp_path)
    # A quad, a regular pentagon and a triangle, all counter-clockwise in the XY plane.
    pent = [(3 + np.cos(a), np.sin(a), 0.0) for a in np.linspace(0, 2 * np.pi, 6)[:-1]]
    pts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)] + pent + [(5, 0, 0), (6, 0, 0), (5, 1, 0)]
    add_mesh(stage, "/World/M", pts, [4, 5, 3], [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11])
    scene = save_and_load(stage, path)
    assert scene.triangle_count == 2 + 3 + 1
    np.testing.assert_allclose(triangle_normals(scene), np.tile([0.0, 0.0, 1.0], (6, 1)), atol=1e-6)
    pent_area = 0.5 * 5 * np.sin(2 * np.pi / 5)
    assert triangle_areas(scene).sum() == pytest.approx(1.0 + pent_area + 0.5, rel=1e-6)
    # Triangles keep the polygon order: first the quad's two, then the pentagon's three.
    assert set(scene.indices[:2].ravel()) == {0, 1, 2, 3}
    assert set(scene.indices[2:5].ravel()) == {4, 5, 6, 7, 8}


def test_concave_polygon_is_ear_clipped():
    # A chevron, counter-clockwise, reflex at vertex 1: a fan from vertex 0 would make
    # a clockwise triangle (0, 1, 2) outside the polygon.
    pts = np.array([(0, 0, 0), (2, 1, 0), (4, 0, 0), (2, 3, 0)], dtype=np.float32)
    tri_corner, tri_face = triangulate(np.array([4]), np.arange(4), pts)
    p = pts[tri_corner].astype(np.float64)
    signed = 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]
    assert len(tri_corner) == 2 and (tri_face == 0).all()
    assert (signed > 0).all()
    assert signed.sum() == pytest.approx(4.0)


def test_hole_indices_drop_faces(tmp_path):
    stage, path = new_stage(tmp_path)
    pts = [(x, y, 0) for y in (0, 1) for x in (0, 1, 2, 3)]  # 2 rows of 4 points
    quads = [[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6]]
    mesh = add_mesh(stage, "/World/M", pts, [4, 4, 4], sum(quads, []))
    mesh.CreateHoleIndicesAttr([1])
    scene = save_and_load(stage, path)
    assert scene.triangle_count == 4
    centroids_x = scene.points[scene.indices].mean(axis=1)[:, 0]
    assert ((centroids_x < 1.0) | (centroids_x > 2.0)).all()  # nothing from the middle face


def test_left_handed_orientation_flips_winding(tmp_path):
    stage, path = new_stage(tmp_path)
    add_mesh(
        stage, "/World/L", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2], Orientation=UsdGeom.Tokens.leftHanded
    )
    add_mesh(stage, "/World/R", [(0, 0, 1), (1, 0, 1), (0, 1, 1)], [3], [0, 1, 2])
    scene = save_and_load(stage, path)
    n = triangle_normals(scene)
    np.testing.assert_allclose(n[0], [0, 0, -1], atol=1e-6)  # left-handed: front faces -Z
    np.testing.assert_allclose(n[1], [0, 0, 1], atol=1e-6)
    # Computed shading normals follow the front side too.
    np.testing.assert_allclose(scene.corner_normals[0], np.tile([0, 0, -1], (3, 1)), atol=1e-6)
    np.testing.assert_allclose(scene.corner_normals[1], np.tile([0, 0, 1], (3, 1)), atol=1e-6)


def test_mirroring_transform_keeps_winding_and_normals_consistent(tmp_path):
    stage, path = new_stage(tmp_path)
    x = UsdGeom.Xform.Define(stage, "/World/Mirror")
    x.AddScaleOp().Set(Gf.Vec3f(-1, 1, 1))
    add_mesh(
        stage,
        "/World/Mirror/T",
        [(0, 0, 0), (1, 0, 0), (0, 1, 0)],
        [3],
        [0, 1, 2],
        Normals=Vt.Vec3fArray([Gf.Vec3f(0, 0, 1)] * 3),
    )
    scene = save_and_load(stage, path)
    np.testing.assert_allclose(scene.points[:, 0], [0, -1, 0], atol=1e-6)
    np.testing.assert_allclose(scene.corner_normals[0], np.tile([0, 0, 1], (3, 1)), atol=1e-6)
    np.testing.assert_allclose(triangle_normals(scene)[0], [0, 0, 1], atol=1e-6)


def _two_tris(stage, path="/World/M"):
    """Two triangles sharing the edge 1-2 (4 points, 6 face-vertices), facing +Z."""
    return add_mesh(stage, path, [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)], [3, 3], [0, 1, 2, 2, 1, 3])


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


NORMALS = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0.6, 0.8), (0.6, 0, 0.8), (0.8, 0.6, 0)]


@pytest.mark.parametrize("interpolation", ["vertex", "faceVarying", "uniform", "constant"])
def test_normals_interpolations(tmp_path, interpolation):
    stage, path = new_stage(tmp_path)
    mesh = _two_tris(stage)
    count = {"vertex": 4, "faceVarying": 6, "uniform": 2, "constant": 1}[interpolation]
    values = NORMALS[:count]
    mesh.CreateNormalsAttr([Gf.Vec3f(*v) for v in values])
    mesh.SetNormalsInterpolation(interpolation)
    scene = save_and_load(stage, path)
    v = np.asarray(values, dtype=np.float64)
    fvi = np.array([[0, 1, 2], [2, 1, 3]])
    corner_index = {
        "vertex": fvi,
        "faceVarying": np.arange(6).reshape(2, 3),
        "uniform": np.array([[0, 0, 0], [1, 1, 1]]),
        "constant": np.zeros((2, 3), dtype=int),
    }[interpolation]
    np.testing.assert_allclose(scene.corner_normals, _unit(v[corner_index]), atol=1e-6)


def test_indexed_primvar_normals_override_normals_attribute(tmp_path):
    stage, path = new_stage(tmp_path)
    mesh = _two_tris(stage)
    mesh.CreateNormalsAttr([Gf.Vec3f(1, 0, 0)] * 4)  # must be ignored
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
        "normals", Sdf.ValueTypeNames.Normal3fArray, UsdGeom.Tokens.faceVarying
    )
    pv.Set([Gf.Vec3f(0, 0, 2), Gf.Vec3f(0, 3, 0)])  # not unit: must be normalised
    pv.SetIndices(Vt.IntArray([0, 0, 1, 1, 0, 1]))
    scene = save_and_load(stage, path)
    expected = np.array([(0, 0, 1), (0, 0, 1), (0, 1, 0), (0, 1, 0), (0, 0, 1), (0, 1, 0)], dtype=np.float64)
    np.testing.assert_allclose(scene.corner_normals.reshape(-1, 3), expected, atol=1e-6)


def test_computed_normals_are_area_weighted_smooth(tmp_path):
    stage, path = new_stage(tmp_path)
    # A tent: triangle A (area 1, normal +Z) and triangle B (area sqrt(2)/2... ) share edge 0-1.
    add_mesh(stage, "/World/T", [(0, 0, 0), (2, 0, 0), (1, 1, 0), (1, -1, 1)], [3, 3], [0, 1, 2, 1, 0, 3])
    scene = save_and_load(stage, path)
    p = np.array([(0, 0, 0), (2, 0, 0), (1, 1, 0), (1, -1, 1)], dtype=np.float64)
    fa = np.cross(p[1] - p[0], p[2] - p[0])
    fb = np.cross(p[0] - p[1], p[3] - p[1])
    shared = _unit(fa + fb)
    np.testing.assert_allclose(scene.corner_normals[0, 0], shared, atol=1e-6)  # point 0
    np.testing.assert_allclose(scene.corner_normals[0, 2], _unit(fa), atol=1e-6)  # point 2 only in A
    np.testing.assert_allclose(scene.corner_normals[1, 2], _unit(fb), atol=1e-6)  # point 3 only in B


@pytest.mark.parametrize("interpolation", ["vertex", "faceVarying", "uniform", "constant", "indexed"])
def test_st_interpolations(tmp_path, interpolation):
    stage, path = new_stage(tmp_path)
    mesh = _two_tris(stage)
    api = UsdGeom.PrimvarsAPI(mesh)
    uv = np.array([(0, 0), (1, 0), (0, 1), (1, 1), (0.5, 0.25), (0.25, 0.5)], dtype=np.float64)
    fvi = np.array([[0, 1, 2], [2, 1, 3]])
    if interpolation == "indexed":
        pv = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
        pv.Set([Gf.Vec2f(*uv[4]), Gf.Vec2f(*uv[5])])
        pv.SetIndices(Vt.IntArray([1, 0, 0, 1, 1, 0]))
        expected = uv[[5, 4, 4, 5, 5, 4]].reshape(2, 3, 2)
    else:
        count = {"vertex": 4, "faceVarying": 6, "uniform": 2, "constant": 1}[interpolation]
        pv = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, interpolation)
        pv.Set([Gf.Vec2f(*u) for u in uv[:count]])
        corner_index = {
            "vertex": fvi,
            "faceVarying": np.arange(6).reshape(2, 3),
            "uniform": np.array([[0, 0, 0], [1, 1, 1]]),
            "constant": np.zeros((2, 3), dtype=int),
        }[interpolation]
        expected = uv[corner_index]
    scene = save_and_load(stage, path)
    np.testing.assert_allclose(scene.corner_uvs, expected, atol=1e-6)


def test_wrong_primvar_counts_warn_and_fall_back(tmp_path):
    stage, path = new_stage(tmp_path)
    mesh = _two_tris(stage)
    mesh.CreateNormalsAttr([Gf.Vec3f(1, 0, 0)] * 3)  # vertex needs 4
    mesh.SetNormalsInterpolation("vertex")
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "faceVarying").Set(
        [Gf.Vec2f(1, 1)] * 5
    )
    scene = save_and_load(stage, path)
    np.testing.assert_allclose(scene.corner_normals.reshape(-1, 3), np.tile([0, 0, 1], (6, 1)), atol=1e-6)
    np.testing.assert_array_equal(scene.corner_uvs, 0.0)
    assert any("/World/M" in w and "normals has 3 values" in w and "vertex" in w for w in scene.warnings)
    assert any("/World/M" in w and "st has 5 values" in w for w in scene.warnings)


def test_degenerate_faces_warn_and_are_skipped(tmp_path):
    stage, path = new_stage(tmp_path)
    add_mesh(stage, "/World/M", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [2, 3, 1], [0, 1, 0, 1, 2, 2])
    scene = save_and_load(stage, path)
    assert scene.triangle_count == 1
    assert any("/World/M" in w and "2 faces have fewer than 3 vertices" in w for w in scene.warnings)


def test_nested_time_sampled_transforms(tmp_path):
    stage, path = new_stage(tmp_path)
    parent = UsdGeom.Xform.Define(stage, "/World/P")
    op = parent.AddTranslateOp()
    op.Set(Gf.Vec3d(0, 0, 0), 0.0)
    op.Set(Gf.Vec3d(10, 0, 0), 10.0)
    child = UsdGeom.Xform.Define(stage, "/World/P/C")
    child.AddRotateZOp().Set(90.0)
    child.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    add_mesh(stage, "/World/P/C/M", [(1, 0, 0), (1, 1, 0), (0, 1, 0)], [3], [0, 1, 2])
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(10)
    s0 = save_and_load(stage, path, 0.0)
    s5 = save_and_load(stage, path, 5.0)
    # scale 2 then rotate 90 degrees about Z: (x, y) -> (-2y, 2x); then translate.
    expected = np.array([(0, 2, 0), (-2, 2, 0), (-2, 0, 0)], dtype=np.float64)
    np.testing.assert_allclose(s0.points, expected, atol=1e-5)
    np.testing.assert_allclose(s5.points, expected + [5, 0, 0], atol=1e-5)
    np.testing.assert_allclose(s5.corner_normals[0], np.tile([0, 0, 1], (3, 1)), atol=1e-6)
    assert s0.meshes[0].animated


def test_instanceable_references_share_prototype(tmp_path):
    stage, path = new_stage(tmp_path)
    proto = UsdGeom.Xform.Define(stage, "/Proto")
    add_mesh(stage, "/Proto/Tri", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    for name, x in (("A", 10.0), ("B", 20.0)):
        inst = UsdGeom.Xform.Define(stage, f"/World/{name}")
        inst.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        inst.GetPrim().GetReferences().AddInternalReference(proto.GetPath())
        inst.GetPrim().SetInstanceable(True)
    stage.GetPrimAtPath("/Proto").SetSpecifier(Sdf.SpecifierClass)  # the source itself is not drawn
    scene = save_and_load(stage, path)
    assert stage.GetPrimAtPath("/World/A").IsInstance()
    assert [m.prim_path for m in scene.meshes] == ["/World/A/Tri", "/World/B/Tri"]
    np.testing.assert_allclose(scene.points[:, 0], [10, 11, 10, 20, 21, 20], atol=1e-6)


def test_point_instancer(tmp_path):
    stage, path = new_stage(tmp_path)
    pi = UsdGeom.PointInstancer.Define(stage, "/World/PI")
    tri = UsdGeom.Xform.Define(stage, "/World/PI/Protos/Tri")
    add_mesh(stage, "/World/PI/Protos/Tri/M", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    quad = UsdGeom.Xform.Define(stage, "/World/PI/Protos/Quad")
    quad.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))  # prototype root transform applies to its instances
    add_mesh(stage, "/World/PI/Protos/Quad/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4], [0, 1, 2, 3])
    pi.CreatePrototypesRel().SetTargets([tri.GetPath(), quad.GetPath()])
    pi.CreateProtoIndicesAttr([0, 1, 0, 1, 0])
    pi.CreatePositionsAttr([Gf.Vec3f(10 * i, 0, 0) for i in range(5)])
    pi.CreateInvisibleIdsAttr([4])  # hides the fifth instance
    scene = save_and_load(stage, path)
    # two triangles (instances 0, 2) + two quads (1, 3) of 2 triangles = 6 triangles
    assert scene.triangle_count == 2 * 1 + 2 * 2
    assert len(scene.meshes) == 4
    origins = sorted(tuple(np.round(scene.points[m.first_point], 4)) for m in scene.meshes)
    assert origins == [(0, 0, 0), (10, 0, 5), (20, 0, 0), (30, 0, 5)]


def test_invisible_guide_and_proxy_prims_are_skipped(tmp_path):
    stage, path = new_stage(tmp_path)
    hidden = UsdGeom.Xform.Define(stage, "/World/Hidden")
    hidden.MakeInvisible()
    add_mesh(stage, "/World/Hidden/M", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    guide = UsdGeom.Xform.Define(stage, "/World/Guide")
    guide.CreatePurposeAttr(UsdGeom.Tokens.guide)
    add_mesh(stage, "/World/Guide/M", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    back = add_mesh(stage, "/World/Guide/RenderChild", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    back.CreatePurposeAttr(UsdGeom.Tokens.render)  # an authored purpose overrides the inherited one
    proxy = add_mesh(stage, "/World/Proxy", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    proxy.CreatePurposeAttr(UsdGeom.Tokens.proxy)
    render = add_mesh(stage, "/World/Render", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    render.CreatePurposeAttr(UsdGeom.Tokens.render)
    add_mesh(stage, "/World/Default", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    scene = save_and_load(stage, path)
    assert [m.prim_path for m in scene.meshes] == ["/World/Guide/RenderChild", "/World/Render", "/World/Default"]


def test_unsupported_prims_are_reported_once_by_name(tmp_path):
    stage, path = new_stage(tmp_path)
    UsdGeom.Points.Define(stage, "/World/Ball")
    UsdGeom.BasisCurves.Define(stage, "/World/Hair")
    add_mesh(stage, "/World/Sub", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2], subdivision="bogus")
    from warp_hybrid.scene.usd.loader import UsdSceneSource

    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    source.scene_at(0.0)
    scene = source.scene_at(1.0)
    ball = [w for w in scene.warnings if w.startswith("/World/Ball:")]
    hair = [w for w in scene.warnings if w.startswith("/World/Hair:")]
    sub = [w for w in scene.warnings if w.startswith("/World/Sub:")]
    assert len(ball) == 1 and "Points" in ball[0]
    assert len(hair) == 1 and "BasisCurves" in hair[0]
    assert len(sub) == 1 and "control cage" in sub[0]
    assert scene.triangle_count == 1


def test_geom_subset_materials_per_face(tmp_path):
    from usd_stage_kit import bind, preview_material

    stage, path = new_stage(tmp_path)
    pts = [(x, y, 0) for y in (0, 1) for x in (0, 1, 2, 3)]
    mesh = add_mesh(stage, "/World/M", pts, [4, 4, 4], [0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6])
    red, _ = preview_material(stage, "/World/Looks/Red", diffuseColor=(1.0, 0.0, 0.0))
    blue, _ = preview_material(stage, "/World/Looks/Blue", diffuseColor=(0.0, 0.0, 1.0))
    bind(mesh, red)
    subset = UsdGeom.Subset.CreateGeomSubset(mesh, "middle", UsdGeom.Tokens.face, Vt.IntArray([1]), "materialBind")
    bind(subset, blue)
    scene = save_and_load(stage, path)
    names = [scene.materials[i].name for i in scene.triangle_material]
    assert names == ["/World/Looks/Red"] * 2 + ["/World/Looks/Blue"] * 2 + ["/World/Looks/Red"] * 2
