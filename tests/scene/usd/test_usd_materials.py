"""UsdShade binding and UsdPreviewSurface / UsdUVTexture parsing, texture decoding."""

from __future__ import annotations

import logging

import cv2
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade
from usd_stage_kit import bind, new_stage, preview_material, save_and_load, unit_quad

from warp_hybrid.scene.model import Wrap
from warp_hybrid.scene.usd.textures import CHECKER_NAME, srgb_to_linear


def _material_of(scene, mesh_path: str):
    r = next(m for m in scene.meshes if m.prim_path == mesh_path)
    return scene.materials[int(scene.triangle_material[r.first_triangle])]


def test_binding_inheritance_and_fallbacks(tmp_path):
    stage, path = new_stage(tmp_path)
    red, _ = preview_material(stage, "/World/Looks/Red", diffuseColor=(1.0, 0.0, 0.0))
    blue, _ = preview_material(stage, "/World/Looks/Blue", diffuseColor=(0.0, 0.0, 1.0))
    group = UsdGeom.Xform.Define(stage, "/World/G")
    bind(group, red)
    unit_quad(stage, "/World/G/Inherits")
    bind(unit_quad(stage, "/World/G/Own"), blue)
    unit_quad(stage, "/World/Plain")
    coloured = unit_quad(stage, "/World/Coloured")
    coloured.CreateDisplayColorAttr([Gf.Vec3f(0.2, 0.4, 0.6)])
    scene = save_and_load(stage, path)
    assert _material_of(scene, "/World/G/Inherits").name == "/World/Looks/Red"
    assert _material_of(scene, "/World/G/Own").name == "/World/Looks/Blue"
    plain = _material_of(scene, "/World/Plain")
    assert plain.name == "<default>" and plain.diffuse == (0.18, 0.18, 0.18)
    col = _material_of(scene, "/World/Coloured")
    np.testing.assert_allclose(col.diffuse, (0.2, 0.4, 0.6), rtol=1e-6)


def test_preview_surface_constants_and_custom_data(tmp_path):
    stage, path = new_stage(tmp_path)
    mat, _ = preview_material(
        stage,
        "/World/Looks/Glass",
        diffuseColor=(0.9, 0.8, 0.7),
        emissiveColor=(1.0, 2.0, 3.0),
        specularColor=(0.5, 0.4, 0.3),
        useSpecularWorkflow=1,
        metallic=0.25,
        roughness=0.1,
        opacity=0.0,
        opacityThreshold=0.0,
        ior=1.33,
    )
    mat.GetPrim().SetCustomDataByKey("sa:thinWalled", True)
    mat.GetPrim().SetCustomDataByKey("sa:attenuationColor", Gf.Vec3f(0.1, 0.2, 0.3))
    mat.GetPrim().SetCustomDataByKey("sa:attenuationDistance", 2.5)
    mesh = unit_quad(stage, "/World/Q")
    mesh.CreateDoubleSidedAttr(True)
    bind(mesh, mat)
    bind(unit_quad(stage, "/World/Q2", z=1.0), mat)
    scene = save_and_load(stage, path)
    m = _material_of(scene, "/World/Q")
    np.testing.assert_allclose(m.diffuse, (0.9, 0.8, 0.7), rtol=1e-6)
    np.testing.assert_allclose(m.emissive, (1.0, 2.0, 3.0), rtol=1e-6)
    np.testing.assert_allclose(m.specular, (0.5, 0.4, 0.3), rtol=1e-6)
    assert m.use_specular_workflow
    assert (m.metallic, m.roughness, m.opacity, m.opacity_threshold) == pytest.approx((0.25, 0.1, 0.0, 0.0))
    assert m.ior == pytest.approx(1.33)
    assert m.thin_walled and m.attenuation_distance == pytest.approx(2.5)
    np.testing.assert_allclose(m.attenuation_color, (0.1, 0.2, 0.3), rtol=1e-6)
    # doubleSided comes from the mesh: the same material gives two entries.
    assert m.double_sided and not _material_of(scene, "/World/Q2").double_sided
    assert _material_of(scene, "/World/Q2").name == m.name


def _texture(stage, mat_path: str, name: str, file: str, **inputs) -> UsdShade.Shader:
    tex = UsdShade.Shader.Define(stage, f"{mat_path}/{name}")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    for key, value in inputs.items():
        if key in ("scale", "bias"):
            tex.CreateInput(key, Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*value))
        else:
            tex.CreateInput(key, Sdf.ValueTypeNames.Token).Set(value)
    return tex


def _reader(stage, mat_path: str, varname: str) -> UsdShade.Shader:
    reader = UsdShade.Shader.Define(stage, f"{mat_path}/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set(varname)
    return reader


def _connect(shader, name, type_name, source, output):
    shader.CreateInput(name, type_name).ConnectToSource(source.ConnectableAPI(), output)


def _write_png(path, bgr):
    assert cv2.imwrite(str(path), np.asarray(bgr))


def test_texture_channels_scale_bias_wrap_and_uv_set(tmp_path):
    _write_png(tmp_path / "a.png", np.full((2, 2, 4), (10, 20, 30, 40), np.uint8))
    _write_png(tmp_path / "b.png", np.full((2, 2, 3), (50, 60, 70), np.uint8))
    _write_png(tmp_path / "c.png", np.full((2, 2, 3), (0, 0, 255), np.uint8))  # red
    stage, path = new_stage(tmp_path)
    mat, surf = preview_material(stage, "/World/Looks/T")
    a = _texture(
        stage,
        "/World/Looks/T",
        "A",
        "a.png",
        scale=(2, 2, 2, 1),
        bias=(0.1, 0.1, 0.1, 0),
        wrapS="clamp",
        wrapT="mirror",
        sourceColorSpace="sRGB",
    )
    b = _texture(stage, "/World/Looks/T", "B", "b.png", wrapS="black", sourceColorSpace="raw")
    c = _texture(stage, "/World/Looks/T", "C", "c.png", scale=(3, 1, 1, 1), bias=(0.5, 0, 0, 0))
    reader = _reader(stage, "/World/Looks/T", "uv2")
    for tex in (a, b, c):
        _connect(tex, "st", Sdf.ValueTypeNames.Float2, reader, "result")
    _connect(surf, "diffuseColor", Sdf.ValueTypeNames.Color3f, a, "rgb")
    _connect(surf, "opacity", Sdf.ValueTypeNames.Float, a, "a")
    _connect(surf, "roughness", Sdf.ValueTypeNames.Float, b, "g")
    _connect(surf, "metallic", Sdf.ValueTypeNames.Float, b, "b")
    _connect(surf, "emissiveColor", Sdf.ValueTypeNames.Color3f, c, "r")
    surf.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    mesh = unit_quad(stage, "/World/Q")
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("uv2", Sdf.ValueTypeNames.TexCoord2fArray, "vertex")
    pv.Set([Gf.Vec2f(0.5, 0.5)] * 4)
    bind(mesh, mat)
    scene = save_and_load(stage, path)
    m = _material_of(scene, "/World/Q")
    da = scene.textures[m.diffuse_texture]
    assert m.diffuse_texture == m.opacity_texture  # one binding for one texture node
    assert (da.wrap_s, da.wrap_t) == (Wrap.CLAMP, Wrap.MIRROR)
    assert da.scale == (2, 2, 2, 1) and da.bias == pytest.approx((0.1, 0.1, 0.1, 0.0))
    assert m.opacity_channel == 3 and m.is_cutout
    rb = scene.textures[m.roughness_texture]
    assert m.roughness_texture == m.metallic_texture
    assert (m.roughness_channel, m.metallic_channel) == (1, 2)
    assert (rb.wrap_s, rb.wrap_t) == (Wrap.BLACK, Wrap.REPEAT)  # wrapT unauthored: useMetadata -> repeat
    # raw: 8-bit values / 255, BGR -> RGB
    np.testing.assert_allclose(scene.images[rb.image].pixels[0, 0], (70 / 255, 60 / 255, 50 / 255, 1.0), atol=1e-6)
    # sRGB: colour decoded, alpha linear
    np.testing.assert_allclose(
        scene.images[da.image].pixels[0, 0], [*srgb_to_linear(np.array([30, 20, 10]) / 255.0), 40 / 255], atol=1e-6
    )
    # emissive reads the red channel: the image repeats it in r, g, b and the scale/bias follow
    em = scene.textures[m.emissive_texture]
    np.testing.assert_allclose(scene.images[em.image].pixels[0, 0, :3], [1.0, 1.0, 1.0], atol=1e-6)
    assert em.scale == (3, 3, 3, 1) and em.bias == (0.5, 0.5, 0.5, 0.0)
    np.testing.assert_allclose(scene.corner_uvs, 0.5)  # the material's varname uv2 was read
    assert not scene.warnings or all("Camera" in w or w.startswith("no lights") for w in scene.warnings)


def test_srgb_decode_and_orientation_of_png(tmp_path):
    img = np.zeros((2, 3, 3), np.uint8)
    img[0] = (0, 0, 255)  # top row red (BGR)
    img[1] = (128, 128, 128)
    _write_png(tmp_path / "t.png", img)
    stage, path = new_stage(tmp_path)
    for space in ("sRGB", "raw", "auto"):
        mat, surf = preview_material(stage, f"/World/Looks/{space}")
        tex = _texture(stage, f"/World/Looks/{space}", "Tex", "t.png", sourceColorSpace=space)
        _connect(surf, "diffuseColor", Sdf.ValueTypeNames.Color3f, tex, "rgb")
        bind(unit_quad(stage, f"/World/{space}"), mat)
    scene = save_and_load(stage, path)
    px = {
        space: scene.images[scene.textures[_material_of(scene, f"/World/{space}").diffuse_texture].image].pixels
        for space in ("sRGB", "raw", "auto")
    }
    assert px["sRGB"].shape == (2, 3, 4) and px["sRGB"].dtype == np.float32
    np.testing.assert_allclose(px["sRGB"][0, 0], (1, 0, 0, 1), atol=1e-6)  # row 0 is the top
    assert px["sRGB"][1, 2, 0] == pytest.approx(0.2158605, abs=1e-6)  # sRGB 128 -> linear
    assert px["raw"][1, 2, 0] == pytest.approx(128 / 255, abs=1e-6)
    np.testing.assert_array_equal(px["auto"], px["sRGB"])  # 8-bit colour: auto = sRGB
    assert len(scene.images) == 2  # one image per (file, colour space applied): auto shares sRGB's


def test_texture_file_resolves_relative_to_its_layer_through_interface_inputs(tmp_path):
    sub = tmp_path / "looks"
    sub.mkdir()
    _write_png(sub / "wood.png", np.full((1, 1, 3), (0, 255, 0), np.uint8))  # green
    looks = Usd.Stage.CreateNew(str(sub / "looks.usda"))
    mat, surf = preview_material(looks, "/World/Looks/Wood")
    file_in = mat.CreateInput("texFile", Sdf.ValueTypeNames.Asset)
    file_in.Set("wood.png")  # relative to looks/looks.usda
    name_in = mat.CreateInput("stName", Sdf.ValueTypeNames.Token)
    name_in.Set("st")
    tex = UsdShade.Shader.Define(looks, "/World/Looks/Wood/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).ConnectToSource(file_in)
    reader = UsdShade.Shader.Define(looks, "/World/Looks/Wood/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).ConnectToSource(name_in)
    _connect(tex, "st", Sdf.ValueTypeNames.Float2, reader, "result")
    _connect(surf, "diffuseColor", Sdf.ValueTypeNames.Color3f, tex, "rgb")
    looks.GetRootLayer().Save()
    stage, path = new_stage(tmp_path)
    stage.GetRootLayer().subLayerPaths.append("looks/looks.usda")
    mesh = unit_quad(stage, "/World/Q")
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
        [Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]
    )
    bind(mesh, UsdShade.Material(stage.GetPrimAtPath("/World/Looks/Wood")))
    scene = save_and_load(stage, path)
    m = _material_of(scene, "/World/Q")
    img = scene.images[scene.textures[m.diffuse_texture].image]
    assert img.path.endswith("looks/wood.png")
    np.testing.assert_allclose(img.pixels[0, 0], (0, 1, 0, 1), atol=1e-6)
    np.testing.assert_allclose(scene.corner_uvs[0], [[0, 0], [1, 0], [1, 1]], atol=1e-6)


def test_missing_texture_falls_back_to_checker_with_warning(tmp_path, caplog):
    stage, path = new_stage(tmp_path)
    mat, surf = preview_material(stage, "/World/Looks/Broken")
    tex = _texture(stage, "/World/Looks/Broken", "Tex", "textures/nope.png")
    _connect(surf, "diffuseColor", Sdf.ValueTypeNames.Color3f, tex, "rgb")
    bind(unit_quad(stage, "/World/Q"), mat)
    with caplog.at_level(logging.WARNING, logger="warp_hybrid.scene"):
        scene = save_and_load(stage, path)
    m = _material_of(scene, "/World/Q")
    img = scene.images[scene.textures[m.diffuse_texture].image]
    assert img.path == CHECKER_NAME
    magenta, black = (1.0, 0.0, 1.0, 1.0), (0.0, 0.0, 0.0, 1.0)
    np.testing.assert_array_equal(img.pixels[0, 0], magenta)
    np.testing.assert_array_equal(img.pixels[0, 8], black)
    np.testing.assert_array_equal(img.pixels[8, 8], magenta)
    warnings = [w for w in scene.warnings if "nope.png" in w]
    assert len(warnings) == 1 and warnings[0].startswith("/World/Looks/Broken:") and "checker" in warnings[0]
    assert any("nope.png" in r.getMessage() and "/World/Looks/Broken" in r.getMessage() for r in caplog.records)


def test_undecodable_texture_warns_with_file(tmp_path):
    (tmp_path / "bad.png").write_bytes(b"not an image")
    stage, path = new_stage(tmp_path)
    mat, surf = preview_material(stage, "/World/Looks/Bad")
    tex = _texture(stage, "/World/Looks/Bad", "Tex", "bad.png")
    _connect(surf, "roughness", Sdf.ValueTypeNames.Float, tex, "r")
    bind(unit_quad(stage, "/World/Q"), mat)
    scene = save_and_load(stage, path)
    m = _material_of(scene, "/World/Q")
    assert scene.images[scene.textures[m.roughness_texture].image].path == CHECKER_NAME
    assert any("bad.png" in w and w.startswith("/World/Looks/Bad:") for w in scene.warnings)


def test_unsupported_shaders_and_inputs_are_reported(tmp_path):
    stage, path = new_stage(tmp_path)
    mx = UsdShade.Material.Define(stage, "/World/Looks/MX")
    sh = UsdShade.Shader.Define(stage, "/World/Looks/MX/S")
    sh.CreateIdAttr("ND_standard_surface_surfaceshader")
    mx.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    bind(unit_quad(stage, "/World/A"), mx)
    mat, surf = preview_material(stage, "/World/Looks/Bumpy", clearcoat=0.5)
    normal_tex = _texture(stage, "/World/Looks/Bumpy", "N", "n.png")
    _connect(surf, "normal", Sdf.ValueTypeNames.Normal3f, normal_tex, "rgb")
    bind(unit_quad(stage, "/World/B", z=1.0), mat)
    scene = save_and_load(stage, path)
    a = _material_of(scene, "/World/A")
    assert a.name == "/World/Looks/MX" and a.diffuse == (0.18, 0.18, 0.18)
    assert any(w.startswith("/World/Looks/MX:") and "ND_standard_surface_surfaceshader" in w for w in scene.warnings)
    assert any(w.startswith("/World/Looks/Bumpy:") and "normal" in w for w in scene.warnings)
    assert any(w.startswith("/World/Looks/Bumpy:") and "clearcoat" in w for w in scene.warnings)


@pytest.mark.parametrize(
    "ext, pixels, space, applied, expected",
    [
        (".png", np.array([[65535, 0]], np.uint16), "auto", "raw", [(1, 1, 1, 1), (0, 0, 0, 1)]),  # 16-bit grey
        (".png", np.array([[[0, 32768, 65535]]], np.uint16), "raw", "raw", [(1.0, 32768 / 65535, 0.0, 1.0)]),
        (".png", np.array([[[0, 0, 255, 128]]], np.uint8), "auto", "sRGB", [(1, 0, 0, 128 / 255)]),  # alpha linear
        (".exr", np.array([[[0.25, 2.0, 8.0]]], np.float32), "auto", "raw", [(8.0, 2.0, 0.25, 1.0)]),  # float
    ],
)
def test_decode_image_depths_and_channels(tmp_path, ext, pixels, space, applied, expected):
    from warp_hybrid.scene.usd.textures import load_image

    f = tmp_path / f"img{ext}"
    assert cv2.imwrite(str(f), pixels)
    out, used = load_image(str(f), space)
    assert used == applied
    np.testing.assert_allclose(out.reshape(-1, 4), expected, rtol=1e-3, atol=1e-6)
