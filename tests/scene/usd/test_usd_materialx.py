"""MaterialX networks: usd-core has no MaterialX plugin, so a material whose only
surface is MaterialX is drawn default grey with one warning naming it; a material that
also has a UsdPreviewSurface on its universal surface uses that, without a warning."""

from __future__ import annotations

import numpy as np
from pxr import UsdShade
from usd_stage_kit import bind, materialx_surface, new_stage, preview_material, save_and_load, unit_quad

from warp_hybrid.scene.model import Material

LOOK = "/World/Looks/Steel"


def _materialx_warning(source: str) -> str:
    return (
        f"{LOOK}: material is a MaterialX network ({source}); MaterialX is not supported (usd-core has no "
        "MaterialX plugin) and the material has no UsdPreviewSurface on outputs:surface; using default grey"
    )


MATERIALX_WARNING = _materialx_warning(f"outputs:mtlx:surface -> {LOOK}/Std, id 'ND_standard_surface_surfaceshader'")


def _material_of(scene, prim_path: str) -> Material:
    r = next(m for m in scene.meshes if m.prim_path == prim_path)
    return scene.materials[scene.triangle_material[r.first_triangle]]


def _about_look(scene) -> list[str]:
    return [w for w in scene.warnings if LOOK in w or "MaterialX" in w]


def test_only_materialx_is_default_grey_with_one_warning(tmp_path):
    stage, path = new_stage(tmp_path)
    materialx_surface(stage, UsdShade.Material.Define(stage, LOOK))
    bind(unit_quad(stage, "/World/Q"), UsdShade.Material.Get(stage, LOOK))
    scene = save_and_load(stage, path)
    material = _material_of(scene, "/World/Q")
    assert material.name == LOOK
    assert material.diffuse == Material(LOOK).diffuse == (0.18, 0.18, 0.18)
    assert _about_look(scene) == [MATERIALX_WARNING]


def test_usd_preview_surface_beside_materialx_is_used_without_a_warning(tmp_path):
    stage, path = new_stage(tmp_path)
    mat, _shader = preview_material(stage, LOOK, diffuseColor=(0.2, 0.4, 0.6), roughness=0.3)
    materialx_surface(stage, mat)
    assert [o.GetBaseName() for o in mat.GetSurfaceOutputs()] == ["surface", "mtlx:surface"]
    bind(unit_quad(stage, "/World/Q"), mat)
    scene = save_and_load(stage, path)
    material = _material_of(scene, "/World/Q")
    np.testing.assert_allclose(material.diffuse, (0.2, 0.4, 0.6), rtol=1e-6)
    assert abs(material.roughness - 0.3) < 1e-6
    assert _about_look(scene) == []


def test_materialx_material_on_two_meshes_warns_once(tmp_path):
    stage, path = new_stage(tmp_path)
    mat = UsdShade.Material.Define(stage, LOOK)
    materialx_surface(stage, mat)
    bind(unit_quad(stage, "/World/A"), mat)
    b = unit_quad(stage, "/World/B", z=1.0)
    b.CreateDoubleSidedAttr(True)  # a second table entry of the same USD material
    bind(b, mat)
    scene = save_and_load(stage, path)
    assert _material_of(scene, "/World/A").diffuse == _material_of(scene, "/World/B").diffuse == (0.18, 0.18, 0.18)
    assert _about_look(scene) == [MATERIALX_WARNING]


def test_materialx_node_on_the_universal_surface_is_named(tmp_path):
    stage, path = new_stage(tmp_path)
    mat = UsdShade.Material.Define(stage, LOOK)
    shader = UsdShade.Shader.Define(stage, f"{LOOK}/Std")
    shader.CreateIdAttr("ND_standard_surface_surfaceshader")
    mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "out")
    bind(unit_quad(stage, "/World/Q"), mat)
    scene = save_and_load(stage, path)
    assert _material_of(scene, "/World/Q").diffuse == (0.18, 0.18, 0.18)
    expected = _materialx_warning(f"outputs:surface -> {LOOK}/Std, id 'ND_standard_surface_surfaceshader'")
    assert _about_look(scene) == [expected]


def test_unconnected_materialx_output_is_still_named(tmp_path):
    stage, path = new_stage(tmp_path)
    mat = UsdShade.Material.Define(stage, LOOK)
    mat.CreateSurfaceOutput("mtlx")
    bind(unit_quad(stage, "/World/Q"), mat)
    scene = save_and_load(stage, path)
    assert _about_look(scene) == [_materialx_warning("outputs:mtlx:surface")]


def test_material_without_any_surface_keeps_its_warning(tmp_path):
    stage, path = new_stage(tmp_path)
    mat = UsdShade.Material.Define(stage, LOOK)
    mat.CreateSurfaceOutput("ri")
    bind(unit_quad(stage, "/World/Q"), mat)
    scene = save_and_load(stage, path)
    expected = (
        f"{LOOK}: material has no universal UsdPreviewSurface surface (surface outputs: ['surface', 'ri:surface']); "
        "using default grey"
    )
    assert _about_look(scene) == [expected]
