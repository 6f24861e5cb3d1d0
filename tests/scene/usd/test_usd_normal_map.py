"""Normal maps: a UsdPreviewSurface ``normal`` fed by a UsdUVTexture (scale and bias,
uv transform, raw data) perturbs the shading normal in the per-triangle tangent frame
of the uvs.  The maps are the normals of known height fields over a quad, so the
G-buffer ``normal`` AOV and the shading under a distant light are checked against
the analytic normals."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
import warp as wp
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade
from render_kit import add_camera, pixel_rays, render_aovs
from usd_stage_kit import add_mesh, bind, new_stage, preview_material, save_and_load, set_st, st_reader, uv_texture

from warp_hybrid.core.scene_gpu import SceneGPU
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.device.mipmaps import mip_chain
from warp_hybrid.scene.device.surface import SurfaceHit, surface_at, surface_at_grad
from warp_hybrid.scene.model import Wrap
from warp_hybrid.scene.usd.textures import FLAT_NORMAL_NAME, srgb_to_linear

SIZE = 32  # rendered pixels per side
CORNERS = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (1.0, 1.0, 0.0), (-1.0, 1.0, 0.0)]  # the quad [-1, 1]^2, facing +Z
ENCODE = {"scale": (2.0, 2.0, 2.0, 1.0), "bias": (-1.0, -1.0, -1.0, 0.0)}  # the usual [0, 1] -> [-1, 1]
# uv layouts of the quad: u along +x, v along +y; v running down; u' = 1 - v, v' = u through a
# UsdTransform2d (rotation 90, translation (1, 0)).  Each maps a tangent-space (x, y, z) to world.
LAYOUTS = {
    "v_up": (lambda x, y: ((x + 1) / 2, (y + 1) / 2), None, lambda t: (t[0], t[1], t[2])),
    "v_down": (lambda x, y: ((x + 1) / 2, (1 - y) / 2), None, lambda t: (t[0], -t[1], t[2])),
    "rotated": (
        lambda x, y: ((x + 1) / 2, (y + 1) / 2),
        {"rotation": 90.0, "translation": (1.0, 0.0)},
        lambda t: (t[1], -t[0], t[2]),
    ),
}
TILT = np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9])  # the normal of the ramp h = -0.33 s + 0.22 t


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _write_normal_map(path, normals: np.ndarray, encode: bool = True) -> str:
    """Write (H, W, 3) tangent-space normals (row 0 on top) to a float EXR, encoded as
    (n + 1) / 2 (read back with ``ENCODE``) or, with ``encode`` False, as they are."""
    n = np.asarray(normals, np.float32)
    encoded = ((n + 1.0) / 2.0).astype(np.float32) if encode else n
    assert cv2.imwrite(str(path), encoded[..., ::-1], [cv2.IMWRITE_EXR_TYPE, cv2.IMWRITE_EXR_TYPE_FLOAT])
    return path.name


def _quad_stage(tmp_path, layout: str = "v_up", normals=None, camera_z: float = 3.0):
    """A stage with the quad (st per ``layout``, optional authored vertex ``normals``) and
    a camera at (0, 0, ``camera_z``) facing it (turned round when behind the quad)."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    stage, path = new_stage(tmp_path)
    attrs = {"Normals": [Gf.Vec3f(*map(float, n)) for n in normals]} if normals is not None else {}
    quad = add_mesh(stage, "/World/Quad", CORNERS, [4], [0, 1, 2, 3], **attrs)
    set_st(quad, [LAYOUTS[layout][0](x, y) for x, y, _ in CORNERS])
    add_camera(stage, camera_z)
    if camera_z < 0:
        UsdGeom.Xformable(stage.GetPrimAtPath("/World/Cam")).AddRotateYOp().Set(180.0)
    return stage, path, quad


def _matte(stage, quad, normal_map: str | None, layout: str = "v_up", **texture_inputs) -> UsdShade.Shader:
    """Bind a white Lambertian (specular workflow, specularColor 0) to ``quad``, its
    ``normal`` from the map file ``normal_map`` (through the layout's UsdTransform2d)."""
    mat, surface = preview_material(
        stage, "/World/Looks/Bumps", diffuseColor=(1.0, 1.0, 1.0), useSpecularWorkflow=1, specularColor=(0.0, 0.0, 0.0)
    )
    if normal_map is not None:
        st = st_reader(stage, "/World/Looks/Bumps/St")
        transform = LAYOUTS[layout][1]
        if transform is not None:
            turn = UsdShade.Shader.Define(stage, "/World/Looks/Bumps/Turn")
            turn.CreateIdAttr("UsdTransform2d")
            turn.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(st)
            turn.CreateInput("rotation", Sdf.ValueTypeNames.Float).Set(transform["rotation"])
            turn.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*transform["translation"]))
            st = turn.CreateOutput("result", Sdf.ValueTypeNames.Float2)
        rgb = uv_texture(stage, "/World/Looks/Bumps/Normals", normal_map, st, **texture_inputs)
        surface.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(rgb)
    bind(quad, mat)
    return surface


def _on_quad(camera_z: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    """World (x, y) on the quad's plane under each pixel centre (mirrored from behind)."""
    rays = pixel_rays(SIZE, SIZE)[..., :2] * abs(camera_z)
    return (rays[..., 0] if camera_z > 0 else -rays[..., 0]), rays[..., 1]


def _bumps(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """World normals of the height field h = 0.15 sin(pi x) + 0.1 sin(pi y) over the quad."""
    gx, gy = 0.15 * math.pi * np.cos(math.pi * x), 0.1 * math.pi * np.cos(math.pi * y)
    return _unit(np.stack([-gx, -gy, np.ones_like(x)], axis=-1))


def _bumps_map(texels: int) -> np.ndarray:
    """``_bumps`` at the texel centres of a ``texels``-square map (uv = ((x + 1) / 2,
    (y + 1) / 2), row 0 at v = 1): tangent space is world space for the v_up layout."""
    u = (np.arange(texels) + 0.5) / texels
    x, y = np.meshgrid(2 * u - 1, 1 - 2 * u)
    return _bumps(x, y)


def _render(stage, path, device, **settings) -> dict[str, np.ndarray]:
    """Load and render the stage at SIZE x SIZE; its AOVs plus ``hit`` (the quad's pixels)."""
    aovs = render_aovs(save_and_load(stage, path), width=SIZE, height=SIZE, device=device, **settings)
    aovs["hit"] = np.isfinite(aovs["depth"])
    assert aovs["hit"].sum() > 0.7 * SIZE * SIZE
    return aovs


# -- loading ---------------------------------------------------------------------------


def test_normal_input_is_read_as_a_raw_binding_with_its_scale_bias_and_uv(tmp_path):
    rgb = np.array([[[128, 64, 255], [200, 128, 230]]], np.uint8)
    assert cv2.imwrite(str(tmp_path / "n.png"), rgb[..., ::-1])
    stage, path, quad = _quad_stage(tmp_path, "rotated")
    _matte(stage, quad, "n.png", "rotated", wrapS="mirror", wrapT="clamp", **ENCODE)
    scene = save_and_load(stage, path)
    m = scene.materials[scene.triangle_material[0]]
    assert m.normal_texture >= 0 and m.normal_texture in m.texture_slots()
    binding = scene.textures[m.normal_texture]
    assert (binding.scale, binding.bias) == (ENCODE["scale"], ENCODE["bias"])
    assert (binding.wrap_s, binding.wrap_t) == (Wrap.MIRROR, Wrap.CLAMP)
    np.testing.assert_allclose(binding.uv_transform, (0.0, -1.0, 1.0, 1.0, 0.0, 0.0), atol=1e-6)
    # auto colour space on a normal map is raw: the 8-bit values as they are, not sRGB-decoded
    np.testing.assert_allclose(scene.images[binding.image].pixels[0, :, :3], rgb[0] / 255.0, atol=1e-7)
    assert not [w for w in scene.warnings if "normal" in w]


def test_srgb_and_single_channel_normal_maps_are_read_as_authored_and_reported(tmp_path):
    assert cv2.imwrite(str(tmp_path / "n.png"), np.full((2, 2, 3), 128, np.uint8))
    stage, path, quad = _quad_stage(tmp_path)
    surface = _matte(stage, quad, "n.png", sourceColorSpace="sRGB", **ENCODE)
    red = uv_texture(stage, "/World/Looks/Bumps/Normals", "n.png", None, output="r")
    surface.GetInput("normal").ConnectToSource(red)
    scene = save_and_load(stage, path)
    binding = scene.textures[scene.materials[scene.triangle_material[0]].normal_texture]
    np.testing.assert_allclose(scene.images[binding.image].pixels[0, 0, :3], srgb_to_linear(128 / 255), rtol=1e-6)
    node = "/World/Looks/Bumps: normal map /World/Looks/Bumps/Normals"
    assert [w for w in scene.warnings if "normal map" in w] == [
        f"{node} has sourceColorSpace 'sRGB'; decoded as sRGB as authored",
        f"{node} is read through output 'r'; reading rgb",
    ]


def test_missing_normal_map_falls_back_to_a_flat_normal_with_warning(tmp_path):
    stage, path, quad = _quad_stage(tmp_path)
    _matte(stage, quad, "gone.png", **ENCODE)
    scene = save_and_load(stage, path)
    binding = scene.textures[scene.materials[scene.triangle_material[0]].normal_texture]
    image = scene.images[binding.image]
    assert image.path == FLAT_NORMAL_NAME
    np.testing.assert_array_equal(image.pixels.reshape(-1, 4), [(0.0, 0.0, 1.0, 1.0)])
    assert (binding.scale, binding.bias) == ((1.0, 1.0, 1.0, 1.0), (0.0, 0.0, 0.0, 0.0))  # samples (0, 0, 1)
    assert [w for w in scene.warnings if "gone.png" in w] == [
        "/World/Looks/Bumps: texture file 'gone.png' not found; using a flat normal map (the surface's own normals)"
    ]


def test_constant_normal_is_reported_and_the_flat_one_is_not(tmp_path):
    stage, path, quad = _quad_stage(tmp_path)
    surface = _matte(stage, quad, None)
    surface.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).Set(Gf.Vec3f(0.0, 0.0, 1.0))
    assert not [w for w in save_and_load(stage, path).warnings if "normal" in w]
    surface.GetInput("normal").Set(Gf.Vec3f(0.6, 0.0, 0.8))
    scene = save_and_load(stage, path)
    assert scene.materials[scene.triangle_material[0]].normal_texture == -1
    assert [w for w in scene.warnings if "normal" in w] == [
        "/World/Looks/Bumps: UsdPreviewSurface input normal = (0.6, 0, 0.8) is not supported, ignored"
    ]


# -- normals ---------------------------------------------------------------------------


@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_a_ramp_gives_its_constant_tilted_normal_in_every_uv_layout(tmp_path, device, layout):
    stage, path, quad = _quad_stage(tmp_path, layout)
    _matte(stage, quad, _write_normal_map(tmp_path / "ramp.exr", np.broadcast_to(TILT, (4, 4, 3))), layout, **ENCODE)
    aovs = _render(stage, path, device)
    hit = aovs["hit"]
    expected = np.asarray(LAYOUTS[layout][2](TILT), np.float32)
    np.testing.assert_allclose(aovs["normal"][hit], np.broadcast_to(expected, (hit.sum(), 3)), atol=2e-6)


@wp.kernel(enable_backward=False)
def _surfaces(scene: SceneGPU, bary: wp.array(dtype=wp.vec2), d: wp.vec3, out: wp.array(dtype=SurfaceHit)):
    i = wp.tid()
    out[i] = surface_at(scene, i % 2, bary[i][0], bary[i][1], d)


def test_secondary_hits_see_the_same_normal_and_keep_the_face_normal(tmp_path, device):
    stage, path, quad = _quad_stage(tmp_path, "rotated")
    _matte(stage, quad, _write_normal_map(tmp_path / "ramp.exr", np.broadcast_to(TILT, (4, 4, 3))), "rotated", **ENCODE)
    scene = DeviceScene(save_and_load(stage, path), device)
    bary = wp.array(
        np.random.default_rng(1).dirichlet((1, 1, 1), 8)[:, :2].astype(np.float32), dtype=wp.vec2, device=device
    )
    out = wp.empty(8, dtype=SurfaceHit, device=device)
    for d, side in (((0.3, 0.1, -1.0), 1.0), ((0.2, -0.4, 1.0), -1.0)):  # from the front, then from behind
        wp.launch(_surfaces, dim=8, inputs=[scene.gpu, bary, wp.vec3(*d), out], device=device)
        hits = out.numpy()
        np.testing.assert_allclose(
            hits["normal"], np.broadcast_to(side * np.array(LAYOUTS["rotated"][2](TILT)), (8, 3)), atol=2e-6
        )
        np.testing.assert_array_equal(hits["geometric_normal"], np.broadcast_to((0.0, 0.0, side), (8, 3)))


def test_scale_one_and_bias_zero_read_the_texels_as_they_are(tmp_path, device):
    stage, path, quad = _quad_stage(tmp_path)
    _matte(stage, quad, _write_normal_map(tmp_path / "signed.exr", np.broadcast_to(TILT, (4, 4, 3)), encode=False))
    aovs = _render(stage, path, device)
    hit = aovs["hit"]
    np.testing.assert_allclose(aovs["normal"][hit], np.broadcast_to(TILT, (hit.sum(), 3)), atol=2e-6)


def test_the_back_of_the_surface_sees_the_mirrored_normal(tmp_path, device):
    stage, path, quad = _quad_stage(tmp_path, camera_z=-3.0)
    _matte(stage, quad, _write_normal_map(tmp_path / "ramp.exr", np.broadcast_to(TILT, (4, 4, 3))), **ENCODE)
    aovs = _render(stage, path, device)
    hit = aovs["hit"]
    np.testing.assert_allclose(aovs["normal"][hit], np.broadcast_to(-TILT, (hit.sum(), 3)), atol=2e-6)


def test_a_height_field_gives_its_analytic_normals(tmp_path, device):
    stage, path, quad = _quad_stage(tmp_path)
    _matte(stage, quad, _write_normal_map(tmp_path / "bumps.exr", _bumps_map(64)), **ENCODE)  # ~2 texels a pixel
    aovs = _render(stage, path, device)
    hit = aovs["hit"]
    normal = aovs["normal"][hit]
    np.testing.assert_allclose(np.linalg.norm(normal, axis=-1), 1.0, atol=1e-5)
    np.testing.assert_allclose(normal, _bumps(*_on_quad())[hit], atol=1e-2)


@wp.kernel(enable_backward=False)
def _filtered_surfaces(
    scene: SceneGPU,
    tris: wp.array(dtype=wp.int32),
    bary: wp.array(dtype=wp.vec2),
    footprint: wp.vec4,
    out: wp.array(dtype=SurfaceHit),
):
    i = wp.tid()
    out[i] = surface_at_grad(scene, tris[i], bary[i][0], bary[i][1], wp.vec3(0.0, 0.0, -1.0), footprint)


def _barycentrics(scene, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(triangle, (bu, bv)) of the points ``xy`` on the quad (Warp's convention: bu and
    bv weigh the first and second corners)."""
    p = scene.points[scene.indices][:, :, :2].astype(np.float64)  # (T, 3, 2)
    m = np.stack([p[:, 0] - p[:, 2], p[:, 1] - p[:, 2]], axis=-1)  # columns: corner 0 and 1 minus corner 2
    b = np.einsum("tij,ntj->nti", np.linalg.inv(m), xy[:, None, :] - p[None, :, 2])
    inside = (b >= -1e-9).all(axis=-1) & (b.sum(axis=-1) <= 1 + 1e-9)
    tri = inside.argmax(axis=1)
    return tri.astype(np.int32), b[np.arange(len(xy)), tri].astype(np.float32)


def test_minified_normal_maps_read_the_box_filtered_level_renormalised(tmp_path, device):
    normals = _bumps_map(64)
    stage, path, quad = _quad_stage(tmp_path)
    _matte(stage, quad, _write_normal_map(tmp_path / "bumps.exr", normals), **ENCODE)
    scene = DeviceScene(save_and_load(stage, path), device)
    # level 2 (16 x 16 texels, each the mean of a 4 x 4 block): read at its texel centres
    level = mip_chain(((normals + 1) / 2).astype(np.float32))[2] * 2 - 1
    rows, cols = np.meshgrid(np.arange(1, 16, 3), np.arange(1, 16, 3), indexing="ij")
    xy = np.stack([(cols.ravel() + 0.5) / 8 - 1, 1 - (rows.ravel() + 0.5) / 8], axis=-1)
    tris, bary = _barycentrics(scene.scene, xy)
    out = wp.empty(len(xy), dtype=SurfaceHit, device=device)
    footprint = wp.vec4(4.0 / 64, 0.0, 0.0, 4.0 / 64)  # 4 level-0 texels a pixel: lod 2
    inputs = [scene.gpu, wp.array(tris, device=device), wp.array(bary, dtype=wp.vec2, device=device), footprint, out]
    wp.launch(_filtered_surfaces, dim=len(xy), inputs=inputs, device=device)
    hits = out.numpy()
    np.testing.assert_allclose(hits["position"][:, :2], xy, atol=1e-6)
    block_means = level[rows.ravel(), cols.ravel()]
    assert np.linalg.norm(block_means, axis=-1).min() < 0.999  # the filter did shorten them
    np.testing.assert_allclose(np.linalg.norm(hits["normal"], axis=-1), 1.0, atol=1e-6)  # renormalised
    # lod is 2 to within texture_lod's 0.005 (a quarter percent of level 3 blends in); level 0 is 2e-3 away
    np.testing.assert_allclose(hits["normal"], _unit(block_means), atol=3e-4)
    np.testing.assert_allclose(hits["normal"], _bumps(xy[:, 0], xy[:, 1]), atol=3e-2)  # still the height field's


def test_a_flat_map_a_missing_map_and_degenerate_uvs_change_no_bit(tmp_path, device):
    bent = _unit(np.array([(-0.3, -0.2, 1.0), (0.3, -0.1, 1.0), (0.2, 0.3, 1.0), (-0.1, 0.2, 1.0)]))
    frames = {}
    for case in ("none", "flat", "missing", "degenerate"):
        stage, path, quad = _quad_stage(tmp_path / case, normals=bent)
        if case == "degenerate":  # every corner at the same uv: no tangent frame
            set_st(quad, [(0.5, 0.5)] * 4)
        flat = _write_normal_map(tmp_path / case / "flat.exr", np.broadcast_to((0.0, 0.0, 1.0), (4, 4, 3)))
        tilted = _write_normal_map(tmp_path / case / "tilt.exr", np.broadcast_to(TILT, (4, 4, 3)))
        maps = {"none": None, "flat": flat, "missing": "gone.exr", "degenerate": tilted}
        _matte(stage, quad, maps[case], **ENCODE)
        frames[case] = _render(stage, path, device)
    for case in ("flat", "missing", "degenerate"):
        for aov in ("normal", "color"):
            np.testing.assert_array_equal(frames[case][aov], frames["none"][aov], err_msg=f"{case} {aov}")


# -- shading ---------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["raster", "full"])  # the raster G-buffer and the ray-cast primary hits
def test_shading_under_a_distant_light_follows_n_dot_l_of_the_perturbed_normal(tmp_path, device, mode):
    stage, path, quad = _quad_stage(tmp_path)
    _matte(stage, quad, _write_normal_map(tmp_path / "bumps.exr", _bumps_map(64)), **ENCODE)
    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(2.0)
    sun.CreateAngleAttr(0.0)
    sun.AddRotateYOp().Set(40.0)  # photons travel along -(sin 40, 0, cos 40)
    to_light = np.array([math.sin(math.radians(40.0)), 0.0, math.cos(math.radians(40.0))])
    aovs = _render(stage, path, device, mode=mode)
    hit = aovs["hit"]
    n_dot_l = aovs["normal"][hit] @ to_light
    assert n_dot_l.min() < 0.75 < n_dot_l.max()  # the bumps do change the shading
    expected = 2.0 / math.pi * np.maximum(n_dot_l, 0.0)  # white Lambertian: albedo / pi * E * n.l
    np.testing.assert_allclose(aovs["color"][hit], np.repeat(expected[:, None], 3, axis=1), rtol=2e-3, atol=1e-6)
    analytic = _bumps(*_on_quad())[hit] @ to_light
    np.testing.assert_allclose(n_dot_l, analytic, atol=1e-2)
