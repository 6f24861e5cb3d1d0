"""UsdTransform2d between the primvar reader and the UsdUVTexture: scale, rotation and
translation of the texture coordinates, applied where the texture is sampled."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdShade, Vt
from render_kit import add_camera, pixel_rays, render_aovs
from usd_stage_kit import add_mesh, bind, new_stage, preview_material, save_and_load

N = 4  # texels per side


def _texture_pixels() -> np.ndarray:
    """(N, N, 3) distinct colours, row 0 at the top, as the renderer stores them (raw)."""
    k = np.arange(N * N, dtype=np.float64).reshape(N, N)
    return np.stack([k / 15.0, 1.0 - k / 15.0, (k % 3) / 2.0], axis=-1)


def _bilinear_repeat(pixels: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear lookup between texel centres, repeating, at USD uv (v up, row 0 on top)."""
    x = (u % 1.0) * N - 0.5
    y = ((1.0 - v) % 1.0) * N - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]

    def tap(r, c):
        return pixels[r % N, c % N]

    top = tap(y0, x0) * (1 - fx) + tap(y0, x0 + 1) * fx
    bottom = tap(y0 + 1, x0) * (1 - fx) + tap(y0 + 1, x0 + 1) * fx
    return top * (1 - fy) + bottom * fy


def _textured_quad(tmp_path, transform: dict | None):
    """A quad [-1, 1]^2 at z = 0 with st = ((x + 1) / 2, (y + 1) / 2), its diffuse colour
    from an N x N raw PNG through an optional UsdTransform2d, a camera on +Z."""
    rgb = np.round(_texture_pixels() * 255).astype(np.uint8)
    assert cv2.imwrite(str(tmp_path / "grid.png"), rgb[..., ::-1])
    stage, path = new_stage(tmp_path)
    pts = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    quad = add_mesh(stage, "/World/Quad", pts, [4], [0, 1, 2, 3])
    st = quad.GetPrim().CreateAttribute("primvars:st", Sdf.ValueTypeNames.TexCoord2fArray)
    st.Set(Vt.Vec2fArray([Gf.Vec2f((x + 1) / 2, (y + 1) / 2) for x, y, _ in pts]))
    st.SetMetadata("interpolation", "vertex")
    mat, surface = preview_material(stage, "/World/Looks/Grid")
    reader = UsdShade.Shader.Define(stage, "/World/Looks/Grid/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    source = reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
    if transform is not None:
        node = UsdShade.Shader.Define(stage, "/World/Looks/Grid/Turn")
        node.CreateIdAttr("UsdTransform2d")
        node.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(source)
        for name, value in transform.items():
            kind = Sdf.ValueTypeNames.Float if name == "rotation" else Sdf.ValueTypeNames.Float2
            node.CreateInput(name, kind).Set(value)
        source = node.CreateOutput("result", Sdf.ValueTypeNames.Float2)
    tex = UsdShade.Shader.Define(stage, "/World/Looks/Grid/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("grid.png")
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(source)
    rgb_out = tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(rgb_out)
    bind(quad, mat)
    add_camera(stage, 3.0)
    return save_and_load(stage, path)


def test_transform2d_is_read_into_the_binding(tmp_path):
    scene = _textured_quad(tmp_path, {"scale": Gf.Vec2f(2.0, 3.0), "rotation": 90.0, "translation": Gf.Vec2f(1, 0)})
    binding = scene.textures[scene.materials[scene.triangle_material[0]].diffuse_texture]
    # out = R(90) (in * scale) + translation: u' = -3 v + 1, v' = 2 u
    np.testing.assert_allclose(binding.uv_transform, (0.0, -3.0, 1.0, 2.0, 0.0, 0.0), atol=1e-6)
    assert not [w for w in scene.warnings if "UsdTransform2d" in w]


@pytest.mark.parametrize("transform", [None, {"rotation": 90.0, "translation": Gf.Vec2f(1.0, 0.0)}])
def test_rotation_moves_a_known_texel_where_it_should(tmp_path, device, transform):
    scene = _textured_quad(tmp_path, transform)
    aovs = render_aovs(scene, device=device)
    hit = np.isfinite(aovs["depth"])
    on_quad = pixel_rays(48, 36)[..., :2] * 3.0  # the quad's (x, y) under each pixel centre
    u, v = (on_quad[..., 0] + 1) / 2, (on_quad[..., 1] + 1) / 2
    if transform is not None:  # rotate 90 degrees counter-clockwise, then translate by (1, 0)
        u, v = 1.0 - v, u
    expected = _bilinear_repeat(_texture_pixels(), u, v)
    np.testing.assert_allclose(aovs["albedo"][hit], expected[hit], atol=2e-3)
    # The known texel: the top-left texel (row 0, column 0) sits at uv (1/8, 7/8); with the
    # rotation the pixel that shows it is the one whose uv maps there: (u, v) = (7/8, 7/8).
    target = (0.875, 0.875) if transform is not None else (0.125, 0.875)
    x, y = 2 * target[0] - 1, 2 * target[1] - 1
    dist = np.hypot(on_quad[..., 0] - x, on_quad[..., 1] - y)
    j, i = np.unravel_index(np.argmin(dist), dist.shape)
    np.testing.assert_allclose(aovs["albedo"][j, i], _texture_pixels()[0, 0], atol=0.06)
