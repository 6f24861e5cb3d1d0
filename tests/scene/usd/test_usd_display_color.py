"""displayColor with every interpolation kept per corner (not collapsed to its mean),
and UsdPrimvarReader_float3 / _float feeding diffuseColor."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdShade, Vt
from render_kit import add_camera, pixel_rays, render_aovs
from usd_stage_kit import add_mesh, bind, new_stage, preview_material, save_and_load

# Two quads side by side: x in [-1, 0] and [0, 1], y in [-1, 1], at z = 0.
POINTS = [(-1, -1, 0), (0, -1, 0), (1, -1, 0), (-1, 1, 0), (0, 1, 0), (1, 1, 0)]
COUNTS, INDICES = [4, 4], [0, 1, 4, 3, 1, 2, 5, 4]
RED, BLUE, GREEN = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)


def _two_quads(stage, path="/World/M", colours=None, interpolation="constant"):
    mesh = add_mesh(stage, path, POINTS, COUNTS, INDICES)
    if colours is not None:
        pv = mesh.CreateDisplayColorPrimvar(interpolation)
        pv.Set(Vt.Vec3fArray([Gf.Vec3f(*c) for c in colours]))
    return mesh


def _corner_colours(scene, path="/World/M"):
    r = next(m for m in scene.meshes if m.prim_path == path)
    return scene.corner_colors[r.first_triangle : r.first_triangle + r.triangle_count]


def _corner_points(scene, path="/World/M"):
    r = next(m for m in scene.meshes if m.prim_path == path)
    return scene.points[scene.indices[r.first_triangle : r.first_triangle + r.triangle_count]]


@pytest.mark.parametrize("interpolation", ["uniform", "vertex", "varying", "faceVarying"])
def test_display_color_is_kept_per_corner(tmp_path, interpolation):
    stage, path = new_stage(tmp_path)
    colour_of_point = {i: (abs(p[0]), (p[1] + 1) / 2, 0.5) for i, p in enumerate(POINTS)}
    if interpolation == "uniform":
        values = [RED, BLUE]
    elif interpolation == "faceVarying":
        values = [colour_of_point[i] for i in INDICES]
    else:
        values = [colour_of_point[i] for i in range(len(POINTS))]
    _two_quads(stage, colours=values, interpolation=interpolation)
    scene = save_and_load(stage, path)
    material = scene.materials[scene.triangle_material[0]]
    assert material.is_vertex_colored and material.diffuse_primvar == "displayColor"
    colours, corners = _corner_colours(scene), _corner_points(scene)
    if interpolation == "uniform":
        left = corners.mean(axis=1)[:, 0] < 0
        np.testing.assert_allclose(colours[left], np.broadcast_to(RED, colours[left].shape))
        np.testing.assert_allclose(colours[~left], np.broadcast_to(BLUE, colours[~left].shape))
    else:
        expected = np.stack([np.abs(corners[..., 0]), (corners[..., 1] + 1) / 2, np.full(corners.shape[:2], 0.5)], -1)
        np.testing.assert_allclose(colours, expected, atol=1e-6)
    assert not [w for w in scene.warnings if "mean" in w]


def test_constant_display_color_stays_a_material_colour(tmp_path):
    stage, path = new_stage(tmp_path)
    _two_quads(stage, colours=[GREEN, GREEN], interpolation="uniform")  # varies in name only
    scene = save_and_load(stage, path)
    material = scene.materials[scene.triangle_material[0]]
    assert not material.is_vertex_colored and material.diffuse == GREEN
    assert scene.corner_colors.shape == (0, 3, 3)  # nobody reads per-corner colours


def _reader_material(
    stage, varname: str, reader_id: str = "UsdPrimvarReader_float3", fallback=None, name: str = "FromPrimvar"
):
    mat, surface = preview_material(stage, f"/World/Looks/{name}")
    reader = UsdShade.Shader.Define(stage, f"/World/Looks/{name}/Reader")
    reader.CreateIdAttr(reader_id)
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set(varname)
    kind = Sdf.ValueTypeNames.Float3 if reader_id.endswith("float3") else Sdf.ValueTypeNames.Float
    if fallback is not None:
        reader.CreateInput("fallback", kind).Set(fallback)
    out = reader.CreateOutput("result", kind)
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(out)
    return mat


def test_primvar_reader_feeds_diffuse_color_and_renders_per_corner(tmp_path, device):
    stage, path = new_stage(tmp_path)
    values = [(abs(p[0]), (p[1] + 1) / 2, 0.25) for p in POINTS]
    mesh = _two_quads(stage, colours=values, interpolation="vertex")
    bind(mesh, _reader_material(stage, "displayColor"))
    add_camera(stage, 3.0)
    scene = save_and_load(stage, path)
    material = scene.materials[scene.triangle_material[0]]
    assert material.name == "/World/Looks/FromPrimvar" and material.diffuse_primvar == "displayColor"
    albedo = render_aovs(scene, device=device)["albedo"]
    on_quad = pixel_rays(48, 36)[..., :2] * 3.0
    inside = (np.abs(on_quad[..., 0]) < 0.98) & (np.abs(on_quad[..., 1]) < 0.98)
    expected = np.stack([np.abs(on_quad[..., 0]), (on_quad[..., 1] + 1) / 2, np.full(inside.shape, 0.25)], -1)
    np.testing.assert_allclose(albedo[inside], expected[inside], atol=2e-3)  # |x| is linear on each quad


def test_primvar_reader_fallbacks(tmp_path):
    stage, path = new_stage(tmp_path)
    bind(_two_quads(stage), _reader_material(stage, "tint", fallback=Gf.Vec3f(0.3, 0.2, 0.1)))
    grey = _two_quads(stage, "/World/Grey", colours=[RED])
    bind(grey, _reader_material(stage, "displayColor", "UsdPrimvarReader_float", 0.5, "Grey"))
    scene = save_and_load(stage, path)
    np.testing.assert_allclose(_corner_colours(scene), np.broadcast_to((0.3, 0.2, 0.1), (4, 3, 3)), rtol=1e-6)
    assert any(w.startswith("/World/M:") and "'tint'" in w and "fallback" in w for w in scene.warnings)
    np.testing.assert_allclose(_corner_colours(scene, "/World/Grey"), np.broadcast_to(RED, (4, 3, 3)))


def test_instanced_mirrored_corner_colours_follow_their_corners(tmp_path):
    stage, path = new_stage(tmp_path)
    values = [(abs(p[0]), (p[1] + 1) / 2, 0.5) for p in POINTS]
    xf = UsdGeom.Xform.Define(stage, "/World/Mirror")
    xf.AddScaleOp().Set(Gf.Vec3f(-1.0, 1.0, 1.0))
    _two_quads(stage, "/World/Mirror/M", colours=values, interpolation="vertex")
    scene = save_and_load(stage, path)
    corners = _corner_points(scene, "/World/Mirror/M")
    expected = np.stack([np.abs(corners[..., 0]), (corners[..., 1] + 1) / 2, np.full(corners.shape[:2], 0.5)], -1)
    np.testing.assert_allclose(_corner_colours(scene, "/World/Mirror/M"), expected, atol=1e-6)
