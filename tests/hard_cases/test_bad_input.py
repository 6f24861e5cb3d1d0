"""NaN/Inf points or normals are refused with an error naming the file and the prim;
zero-length normals fall back to the geometric normal (issue 10, case 7)."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

from warp_hybrid.errors import SceneError
from warp_hybrid.scene.usd.loader import load_scene


def _quad_stage(tmp_path, points=None, normals=None):
    path = tmp_path / "bad.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Xform.Define(stage, "/World")
    mesh = UsdGeom.Mesh.Define(stage, "/World/Quad")
    mesh.CreatePointsAttr(points or [Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0), Gf.Vec3f(1, 1, 0), Gf.Vec3f(0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr("none")
    if normals is not None:
        mesh.CreateNormalsAttr([Gf.Vec3f(*n) for n in normals])
        mesh.SetNormalsInterpolation("vertex")
    stage.Save()
    return path


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_normals_name_the_prim(tmp_path, bad):
    path = _quad_stage(tmp_path, normals=[(0, 0, 1), (0, 0, 1), (0, bad, 1), (0, 0, 1)])
    with pytest.raises(SceneError, match=r"bad\.usda: /World/Quad: normals value 2 is not finite"):
        load_scene(path)


def test_non_finite_points_name_the_prim(tmp_path):
    pts = [Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0), Gf.Vec3f(1, float("nan"), 0), Gf.Vec3f(0, 1, 0)]
    with pytest.raises(SceneError, match=r"bad\.usda: /World/Quad: point 2 is not finite"):
        load_scene(_quad_stage(tmp_path, points=pts))


def test_zero_length_normals_fall_back_to_the_geometric_normal(tmp_path):
    scene = load_scene(_quad_stage(tmp_path, normals=[(0, 0, 0), (0, 0, 1), (0, 0, 0), (0, 0, 1)]))
    np.testing.assert_allclose(scene.corner_normals.reshape(-1, 3), np.tile([0.0, 0.0, 1.0], (6, 1)), atol=1e-6)
