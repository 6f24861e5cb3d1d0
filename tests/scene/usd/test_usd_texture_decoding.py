"""Texture decoding (16-bit PNG, TGA, one-channel and CMYK JPEG under sourceColorSpace
auto), UsdUVTexture without a file (its fallback) and missing files named one by one."""

from __future__ import annotations

import io

import cv2
import numpy as np
import pytest
from PIL import Image
from pxr import Gf, Sdf, UsdShade
from usd_stage_kit import bind, new_stage, preview_material, save_and_load, unit_quad

from warp_hybrid.scene.usd.textures import decode_image, srgb_to_linear

RAMP8 = np.arange(0, 256, 17, dtype=np.uint8)  # 16 values


def _rgb8() -> np.ndarray:
    """A (4, 4, 3) uint8 RGB image of distinct values."""
    return np.stack([RAMP8.reshape(4, 4), RAMP8[::-1].reshape(4, 4), np.full((4, 4), 128, np.uint8)], -1)


def _textured(stage, name: str, file: str | None, **inputs):
    mat, surface = preview_material(stage, f"/World/Looks/{name}")
    tex = UsdShade.Shader.Define(stage, f"/World/Looks/{name}/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    if file is not None:
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    for key, value in inputs.items():
        tex.CreateInput(key, Sdf.ValueTypeNames.Float4).Set(value)
    out = tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(out)
    bind(unit_quad(stage, f"/World/{name}"), mat)


def _albedo_image(scene, mesh: str) -> np.ndarray:
    r = next(m for m in scene.meshes if m.prim_path == mesh)
    m = scene.materials[scene.triangle_material[r.first_triangle]]
    return scene.images[scene.textures[m.diffuse_texture].image].pixels


def test_16_bit_and_8_bit_png_give_the_same_albedo(tmp_path):
    rgb8 = _rgb8()
    assert cv2.imwrite(str(tmp_path / "eight.png"), rgb8[..., ::-1])
    assert cv2.imwrite(str(tmp_path / "sixteen.png"), (rgb8.astype(np.uint16) * 257)[..., ::-1])
    stage, path = new_stage(tmp_path)
    _textured(stage, "Eight", "eight.png")
    _textured(stage, "Sixteen", "sixteen.png")
    scene = save_and_load(stage, path)
    eight, sixteen = _albedo_image(scene, "/World/Eight"), _albedo_image(scene, "/World/Sixteen")
    np.testing.assert_allclose(eight[..., :3], srgb_to_linear(rgb8 / 255.0), atol=1e-6)  # auto: sRGB
    np.testing.assert_allclose(sixteen, eight, atol=1e-6)


def _encode(image: Image.Image, fmt: str, **options) -> bytes:
    buf = io.BytesIO()
    image.save(buf, fmt, **options)
    return buf.getvalue()


def test_tga_decodes_through_pillow():
    rgb8 = _rgb8()
    pixels, applied = decode_image(_encode(Image.fromarray(rgb8, "RGB"), "TGA"))
    assert applied == "sRGB"
    np.testing.assert_allclose(pixels[..., :3], srgb_to_linear(rgb8 / 255.0), atol=1e-6)
    rgba = np.dstack([rgb8, np.full((4, 4), 51, np.uint8)])
    pixels, _ = decode_image(_encode(Image.fromarray(rgba, "RGBA"), "TGA"), "raw")
    np.testing.assert_allclose(pixels, rgba / 255.0, atol=1e-6)


def test_one_channel_jpeg_is_srgb_under_auto_like_its_rgb_sibling():
    grey = np.full((8, 8), 100, np.uint8)
    single, applied = decode_image(_encode(Image.fromarray(grey, "L"), "JPEG", quality=100))
    assert applied == "sRGB"
    rgb, _ = decode_image(_encode(Image.fromarray(np.dstack([grey] * 3), "RGB"), "JPEG", quality=100))
    np.testing.assert_allclose(single[..., :3], srgb_to_linear(np.full((8, 8, 3), 100 / 255.0)), atol=2e-3)
    np.testing.assert_allclose(single, rgb, atol=2e-3)
    png, raw_space = decode_image(_encode(Image.fromarray(grey, "L"), "PNG"))  # a data map stays raw
    assert raw_space == "raw" and np.allclose(png[..., 0], 100 / 255.0)


@pytest.mark.parametrize(
    "cmyk, rgb", [((255, 0, 0, 0), (0, 1, 1)), ((0, 255, 255, 0), (1, 0, 0)), ((0, 0, 0, 128), None)]
)
def test_cmyk_jpeg_converts_to_rgb(cmyk, rgb):
    pixels, _ = decode_image(_encode(Image.new("CMYK", (8, 8), cmyk), "JPEG", quality=100), "raw")
    expected = rgb if rgb is not None else (1 - 128 / 255,) * 3
    np.testing.assert_allclose(pixels[4, 4, :3], expected, atol=0.02)


def test_texture_without_file_uses_its_fallback(tmp_path):
    stage, path = new_stage(tmp_path)
    _textured(stage, "NoFile", None, fallback=Gf.Vec4f(0.2, 0.4, 0.6, 1.0), scale=Gf.Vec4f(2, 2, 2, 1))
    scene = save_and_load(stage, path)
    m = scene.materials[scene.triangle_material[0]]
    assert m.diffuse_texture == -1 and scene.images == []
    np.testing.assert_allclose(m.diffuse, (0.4, 0.8, 1.2), rtol=1e-6)  # fallback * scale + bias
    assert not [w for w in scene.warnings if "texture" in w]


def test_each_missing_file_is_reported_by_name(tmp_path):
    stage, path = new_stage(tmp_path)
    _textured(stage, "A", "gone_a.png")
    _textured(stage, "B", "gone_b.png")
    scene = save_and_load(stage, path)
    missing = [w for w in scene.warnings if "not found" in w]
    assert len(missing) == 2
    assert any("'gone_a.png'" in w and w.startswith("/World/Looks/A:") for w in missing)
    assert any("'gone_b.png'" in w and w.startswith("/World/Looks/B:") for w in missing)
