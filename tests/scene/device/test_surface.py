"""Shared surface functions: texture sampling (bilinear, wrap modes, v flip, scale/bias),
mip chains and filtered sampling (levels, level of detail, ray differentials),
surface_at (barycentric convention of wp.mesh_query_ray, normals, material) and
opacity_at, checked against numpy references."""

from __future__ import annotations

import re

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.scene_gpu import SceneGPU
from warp_hybrid.errors import SceneError
from warp_hybrid.scene.authoring.builders import MeshInput, make_scene
from warp_hybrid.scene.device import DeviceScene, upload
from warp_hybrid.scene.device.mipmaps import mip_chain, mip_level_count, mip_level_size
from warp_hybrid.scene.device.surface import (
    SurfaceHit,
    opacity_at,
    sample_texture,
    sample_texture_lod,
    surface_at,
    surface_at_grad,
    texture_lod,
    uv_footprint,
)
from warp_hybrid.scene.model import Environment, Material, Scene, TextureBinding, TextureImage, Wrap


@wp.kernel(enable_backward=False)
def _sample(scene: SceneGPU, tex: int, uvs: wp.array(dtype=wp.vec2), out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    out[i] = sample_texture(scene, tex, uvs[i])


@wp.kernel(enable_backward=False)
def _surface(
    scene: SceneGPU,
    tris: wp.array(dtype=wp.int32),
    bary: wp.array(dtype=wp.vec2),
    dirs: wp.array(dtype=wp.vec3),
    out: wp.array(dtype=SurfaceHit),
    opacity: wp.array(dtype=float),
):
    i = wp.tid()
    out[i] = surface_at(scene, tris[i], bary[i][0], bary[i][1], dirs[i])
    opacity[i] = opacity_at(scene, tris[i], bary[i][0], bary[i][1])


@wp.kernel(enable_backward=False)
def _cast(
    scene: SceneGPU,
    starts: wp.array(dtype=wp.vec3),
    dirs: wp.array(dtype=wp.vec3),
    hit_points: wp.array(dtype=wp.vec3),
    surface_points: wp.array(dtype=wp.vec3),
):
    i = wp.tid()
    q = wp.mesh_query_ray(scene.mesh, starts[i], dirs[i], 1.0e6)
    if q.result:
        hit_points[i] = starts[i] + dirs[i] * q.t
        surface_points[i] = surface_at(scene, q.face, q.u, q.v, dirs[i]).position


def _triangle_mesh(material: int = 0) -> MeshInput:
    pts = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]], np.float32)
    normals = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, 0.6, 0.8]], np.float32)
    uvs = np.array([[0.1, 0.2], [0.9, 0.2], [0.1, 0.7]], np.float32)
    return MeshInput(pts, np.array([[0, 1, 2]], np.int32), material, normals, uvs)


def _image(rng: np.random.Generator, h: int = 3, w: int = 4) -> np.ndarray:
    return rng.random((h, w, 4)).astype(np.float32)


def _ref_index(i: np.ndarray, n: int, mode: Wrap) -> np.ndarray:
    if mode == Wrap.REPEAT:
        return np.mod(i, n)
    if mode == Wrap.MIRROR:
        m = np.mod(i, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    if mode == Wrap.CLAMP:
        return np.clip(i, 0, n - 1)
    return np.where((i >= 0) & (i < n), i, -1)


def _ref_sample(img: np.ndarray, uv: np.ndarray, ws: Wrap, wt: Wrap, scale: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """Independent float64 reference: bilinear between texel centres, row 0 at the top."""
    h, w = img.shape[:2]
    x = uv[:, 0].astype(np.float64) * w - 0.5
    y = (1.0 - uv[:, 1].astype(np.float64)) * h - 0.5
    x0 = np.floor(x).astype(np.int64)
    y0 = np.floor(y).astype(np.int64)
    fx = (x - x0)[:, None]
    fy = (y - y0)[:, None]

    def texel(cx: np.ndarray, ry: np.ndarray) -> np.ndarray:
        c = _ref_index(cx, w, ws)
        r = _ref_index(ry, h, wt)
        ok = (c >= 0) & (r >= 0)
        out = img[np.clip(r, 0, h - 1), np.clip(c, 0, w - 1)].astype(np.float64)
        out[~ok] = 0.0
        return out

    top = texel(x0, y0) * (1 - fx) + texel(x0 + 1, y0) * fx
    bottom = texel(x0, y0 + 1) * (1 - fx) + texel(x0 + 1, y0 + 1) * fx
    return (top * (1 - fy) + bottom * fy) * scale + bias


def _texture_scene(img: np.ndarray, bindings: list[TextureBinding]) -> Scene:
    return make_scene(
        [_triangle_mesh()],
        [Material("m")],
        images=[TextureImage("<test>", img)],
        textures=bindings,
    )


WRAP_PAIRS = [(w, w) for w in Wrap] + [(Wrap.REPEAT, Wrap.MIRROR), (Wrap.CLAMP, Wrap.BLACK)]


@pytest.mark.parametrize("wrap_s,wrap_t", WRAP_PAIRS)
def test_sample_texture_matches_bilinear_reference(device: str, wrap_s: Wrap, wrap_t: Wrap) -> None:
    rng = np.random.default_rng(1)
    img = _image(rng)
    scale = np.array([2.0, 0.5, 1.0, -1.0])
    bias = np.array([0.1, 0.0, -0.2, 1.0])
    binding = TextureBinding(0, wrap_s, wrap_t, tuple(scale), tuple(bias))
    ds = DeviceScene(_texture_scene(img, [binding]), device)
    uv = np.concatenate([rng.uniform(-1.3, 2.4, (200, 2)), rng.uniform(0.0, 1.0, (50, 2))]).astype(np.float32)
    out = wp.zeros(len(uv), dtype=wp.vec4, device=device)
    wp.launch(_sample, dim=len(uv), inputs=[ds.gpu, 0, wp.array(uv, dtype=wp.vec2, device=device), out], device=device)
    ref = _ref_sample(img, uv, wrap_s, wrap_t, scale, bias)
    np.testing.assert_allclose(out.numpy(), ref, atol=2e-5)


@pytest.mark.parametrize("wrap", list(Wrap))
def test_non_finite_uv_reads_black(device: str, wrap: Wrap) -> None:
    """A NaN uv (e.g. from a degenerate hit) reads a black texel (then scale and bias),
    never memory outside the image."""
    img = _image(np.random.default_rng(10)) + 1.0
    bias = (0.25, 0.5, 0.75, 1.0)
    ds = DeviceScene(_texture_scene(img, [TextureBinding(0, wrap, wrap, (1.0, 1.0, 1.0, 1.0), bias)]), device)
    uv = np.array([[np.nan, 0.5], [0.5, np.nan], [np.nan, np.nan]], np.float32)
    out = wp.zeros(len(uv), dtype=wp.vec4, device=device)
    wp.launch(_sample, dim=len(uv), inputs=[ds.gpu, 0, wp.array(uv, dtype=wp.vec2, device=device), out], device=device)
    np.testing.assert_array_equal(out.numpy(), np.tile(bias, (len(uv), 1)))


def test_texel_centres_and_v_flip(device: str) -> None:
    """uv at a texel centre returns that texel exactly; v = 1 - (row + 0.5) / h."""
    img = _image(np.random.default_rng(2))
    ds = DeviceScene(_texture_scene(img, [TextureBinding(0)]), device)
    h, w = img.shape[:2]
    rows, cols = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    uv = np.stack([(cols.ravel() + 0.5) / w, 1.0 - (rows.ravel() + 0.5) / h], axis=1).astype(np.float32)
    out = wp.zeros(len(uv), dtype=wp.vec4, device=device)
    wp.launch(_sample, dim=len(uv), inputs=[ds.gpu, 0, wp.array(uv, dtype=wp.vec2, device=device), out], device=device)
    np.testing.assert_allclose(out.numpy(), img.reshape(-1, 4), atol=1e-6)


def _evaluate(
    ds: DeviceScene, device: str, tris: list[int], bary: np.ndarray, dirs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """surface_at and opacity_at for each (triangle, barycentrics, ray direction)."""
    n = len(tris)
    out = wp.zeros(n, dtype=SurfaceHit, device=device)
    opacity = wp.zeros(n, dtype=float, device=device)
    wp.launch(
        _surface,
        dim=n,
        inputs=[
            ds.gpu,
            wp.array(np.asarray(tris, np.int32), dtype=wp.int32, device=device),
            wp.array(bary.astype(np.float32), dtype=wp.vec2, device=device),
            wp.array(dirs.astype(np.float32), dtype=wp.vec3, device=device),
            out,
            opacity,
        ],
        device=device,
    )
    return out.numpy(), opacity.numpy()


def test_surface_geometry_and_facing(device: str) -> None:
    ds = DeviceScene(make_scene([_triangle_mesh()], [Material("m")]), device)
    bary = np.array([[0.2, 0.3], [0.2, 0.3], [0.6, 0.1]])
    dirs = np.array([[0.1, 0.2, -1.0], [0.0, 0.3, 1.0], [0.0, 0.0, -2.0]])
    hits, _ = _evaluate(ds, device, [0, 0, 0], bary, dirs)
    mesh = _triangle_mesh()
    for k in range(3):
        bu, bv = bary[k]
        w = np.array([bu, bv, 1.0 - bu - bv])
        np.testing.assert_allclose(hits["position"][k], w @ mesh.points, atol=1e-6)
        np.testing.assert_allclose(hits["uv"][k], w @ mesh.uvs, atol=1e-6)
        n = w @ mesh.normals
        n /= np.linalg.norm(n)
        front = dirs[k] @ np.array([0.0, 0.0, 1.0]) < 0
        sign = 1.0 if np.dot(n, dirs[k]) < 0 else -1.0
        np.testing.assert_allclose(hits["normal"][k], sign * n, atol=1e-6)
        np.testing.assert_allclose(hits["geometric_normal"][k], [0.0, 0.0, 1.0 if front else -1.0], atol=1e-6)
        assert hits["front_face"][k] == (1 if front else 0)


def test_barycentrics_match_mesh_query_ray(device: str) -> None:
    """surface_at(face, u, v) of a wp.mesh_query_ray hit is the hit point."""
    rng = np.random.default_rng(3)
    pts = rng.uniform(-1, 1, (30, 3)).astype(np.float32)
    pts[:, 2] = rng.uniform(-0.2, 0.2, 30)
    idx = rng.integers(0, 30, (20, 3)).astype(np.int32)
    idx = idx[(idx[:, 0] != idx[:, 1]) & (idx[:, 1] != idx[:, 2]) & (idx[:, 0] != idx[:, 2])]
    ds = DeviceScene(make_scene([MeshInput(pts, idx)], [Material("m")]), device)
    targets = pts[idx].mean(axis=1) + rng.uniform(-0.05, 0.05, (len(idx), 3)).astype(np.float32)
    starts = np.tile(np.array([[0.1, 0.2, 3.0]], np.float32), (len(idx), 1))
    dirs = (targets - starts).astype(np.float32)
    hit_points = wp.zeros(len(idx), dtype=wp.vec3, device=device)
    surface_points = wp.zeros(len(idx), dtype=wp.vec3, device=device)
    wp.launch(
        _cast,
        dim=len(idx),
        inputs=[
            ds.gpu,
            wp.array(starts, dtype=wp.vec3, device=device),
            wp.array(dirs, dtype=wp.vec3, device=device),
            hit_points,
            surface_points,
        ],
        device=device,
    )
    hp = hit_points.numpy()
    assert (np.linalg.norm(hp, axis=1) > 0).mean() > 0.8  # most rays hit something
    np.testing.assert_allclose(surface_points.numpy(), hp, atol=2e-5)


def test_material_metallic_and_specular_workflows(device: str) -> None:
    metal = Material("metal", diffuse=(0.8, 0.4, 0.2), metallic=0.25, roughness=0.3, ior=1.5, emissive=(1.0, 2.0, 3.0))
    spec = Material(
        "spec", diffuse=(0.5, 0.6, 0.7), specular=(0.3, 0.2, 0.1), use_specular_workflow=True, metallic=0.9, ior=1.33
    )
    scene = make_scene([_triangle_mesh(0), _triangle_mesh(1)], [metal, spec])
    ds = DeviceScene(scene, device)
    hits, _ = _evaluate(ds, device, [0, 1], np.array([[0.3, 0.3], [0.3, 0.3]]), np.array([[0, 0, -1.0], [0, 0, -1.0]]))
    d = np.array(metal.diffuse)
    np.testing.assert_allclose(hits["albedo"][0], d * 0.75, atol=1e-6)
    np.testing.assert_allclose(hits["specular"][0], 0.04 * 0.75 + d * 0.25, atol=1e-6)
    np.testing.assert_allclose(hits["emission"][0], metal.emissive, atol=1e-6)
    assert hits["roughness"][0] == pytest.approx(0.3)
    assert hits["metallic"][0] == pytest.approx(0.25)
    assert hits["ior"][0] == pytest.approx(1.5)
    assert hits["material"][0] == 0
    np.testing.assert_allclose(hits["albedo"][1], spec.diffuse, atol=1e-6)
    np.testing.assert_allclose(hits["specular"][1], spec.specular, atol=1e-6)
    assert hits["metallic"][1] == 0.0
    assert hits["material"][1] == 1


def test_textured_material_and_opacity(device: str) -> None:
    rng = np.random.default_rng(4)
    img = _image(rng)
    mat = Material(
        "tex",
        diffuse_texture=0,
        roughness_texture=0,
        roughness_channel=1,
        opacity=1.0,
        opacity_texture=0,
        opacity_channel=3,
        opacity_threshold=0.5,
    )
    plain = Material("plain", opacity=0.3)
    scene = make_scene(
        [_triangle_mesh(0), _triangle_mesh(1)],
        [mat, plain],
        images=[TextureImage("<test>", img)],
        textures=[TextureBinding(0, Wrap.CLAMP, Wrap.CLAMP)],
    )
    ds = DeviceScene(scene, device)
    bary = np.array([[0.2, 0.5], [0.7, 0.1], [0.2, 0.5]])
    hits, opacity = _evaluate(ds, device, [0, 0, 1], bary, np.tile([[0.0, 0.0, -1.0]], (3, 1)))
    mesh = _triangle_mesh()
    for k in range(2):
        w = np.array([bary[k, 0], bary[k, 1], 1 - bary[k].sum()])
        texel = _ref_sample(img, (w @ mesh.uvs)[None], Wrap.CLAMP, Wrap.CLAMP, np.ones(4), np.zeros(4))[0]
        np.testing.assert_allclose(hits["albedo"][k], texel[:3], atol=1e-5)
        assert hits["roughness"][k] == pytest.approx(texel[1], abs=1e-5)
        assert hits["opacity"][k] == pytest.approx(texel[3], abs=1e-5)
        assert opacity[k] == pytest.approx(texel[3], abs=1e-5)
    assert opacity[2] == pytest.approx(0.3)


# --- mip chains and filtered sampling -------------------------------------------------


@wp.kernel(enable_backward=False)
def _sample_lod(
    scene: SceneGPU, tex: int, uvs: wp.array(dtype=wp.vec2), lods: wp.array(dtype=float), out: wp.array(dtype=wp.vec4)
):
    i = wp.tid()
    out[i] = sample_texture_lod(scene, tex, uvs[i], lods[i])


@wp.kernel(enable_backward=False)
def _lod(scene: SceneGPU, tex: int, footprints: wp.array(dtype=wp.vec4), out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = texture_lod(scene, tex, footprints[i])


@wp.kernel(enable_backward=False)
def _footprint(
    scene: SceneGPU,
    origin: wp.vec3,
    dirs: wp.array(dtype=wp.vec3),
    ddx: wp.vec3,
    ddy: wp.vec3,
    out: wp.array(dtype=wp.vec4),
):
    i = wp.tid()
    out[i] = uv_footprint(scene, 0, origin, dirs[i], ddx, ddy)


@wp.kernel(enable_backward=False)
def _surface_grad(
    scene: SceneGPU,
    bary: wp.array(dtype=wp.vec2),
    footprint: wp.vec4,
    out: wp.array(dtype=SurfaceHit),
    plain: wp.array(dtype=SurfaceHit),
):
    i = wp.tid()
    d = wp.vec3(0.0, 0.0, -1.0)
    out[i] = surface_at_grad(scene, 0, bary[i][0], bary[i][1], d, footprint)
    plain[i] = surface_at(scene, 0, bary[i][0], bary[i][1], d)


def _area_mean(img: np.ndarray, width: int, height: int) -> np.ndarray:
    """float64 reference: each texel of a width x height image is the mean of ``img``
    over the block it covers (partial texels weighted by the covered fraction)."""

    def coverage(n: int, m: int) -> np.ndarray:
        edges = np.arange(m + 1) * (n / m)
        lo, hi = edges[:-1, None], edges[1:, None]
        j = np.arange(n)[None, :]
        return np.clip(np.minimum(hi, j + 1) - np.maximum(lo, j), 0.0, None) / (n / m)

    h, w = img.shape[:2]
    return np.einsum("rh,hwk,cw->rck", coverage(h, height), img.astype(np.float64), coverage(w, width))


def test_mip_chain_sizes_and_box_filter() -> None:
    """13 x 6 -> 6 x 3 -> 3 x 1 -> 1 x 1 (floor halving, odd sizes area-weighted); every
    level is the exact area mean of level 0, so the mean colour is kept."""
    img = np.random.default_rng(5).random((6, 13, 4)).astype(np.float32)
    chain = mip_chain(img)
    assert mip_level_count(13, 6) == 4
    assert [level.shape[:2] for level in chain] == [(6, 13), (3, 6), (1, 3), (1, 1)]
    assert [mip_level_size(13, 6, k)[::-1] for k in range(4)] == [(6, 13), (3, 6), (1, 3), (1, 1)]
    np.testing.assert_array_equal(chain[0], img)
    for level in chain[1:]:
        want = _area_mean(img, level.shape[1], level.shape[0])
        np.testing.assert_allclose(level, want, atol=1e-6)
    np.testing.assert_allclose(chain[-1][0, 0], img.reshape(-1, 4).mean(axis=0), atol=1e-6)
    # An even 2 x 2 block and an odd axis, by hand: 3 texels -> 1 weighs them equally.
    two = np.arange(16, dtype=np.float32).reshape(2, 2, 4)
    np.testing.assert_allclose(mip_chain(two)[1][0, 0], two.reshape(-1, 4).mean(axis=0))
    row = np.array([[[0.0] * 4, [3.0] * 4, [9.0] * 4]], np.float32)
    np.testing.assert_allclose(mip_chain(row)[1][0, 0], [4.0] * 4)


def test_device_scene_packs_levels_of_material_textures(device: str) -> None:
    """Material images get their chain right after level 0; an image only the dome light
    uses stays a single level."""
    rng = np.random.default_rng(6)
    img = rng.random((6, 13, 4)).astype(np.float32)
    dome = rng.random((4, 8, 4)).astype(np.float32)
    scene = make_scene(
        [_triangle_mesh()],
        [Material("m", diffuse_texture=0)],
        images=[TextureImage("<img>", img), TextureImage("<dome>", dome)],
        textures=[TextureBinding(0), TextureBinding(1)],
        environment=Environment("/dome", (1.0, 1.0, 1.0), texture=1),
    )
    ds = DeviceScene(scene, device)
    tex = ds.textures.numpy()
    texels = ds.texels.numpy()
    assert list(tex["levels"]) == [4, 1]
    assert list(tex["width"]) == [13, 8] and list(tex["height"]) == [6, 4]
    offset = int(tex["offset"][0])
    starts = tex["level_offsets"][0]
    for k, level in enumerate(mip_chain(img)):
        assert starts[k] == offset
        n = level.shape[0] * level.shape[1]
        np.testing.assert_array_equal(texels[offset : offset + n], level.reshape(-1, 4))
        offset += n
    assert list(starts[4:]) == [starts[3]] * (len(starts) - 4)
    dome_at = int(tex["offset"][1])
    assert offset <= dome_at or dome_at + 32 <= int(tex["offset"][0])
    np.testing.assert_array_equal(texels[dome_at : dome_at + 32], dome.reshape(-1, 4))


def test_texel_pool_past_32_bit_indices_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    """A scene whose textures (with their mip chains) hold more floats than the kernels'
    int texel indices reach is refused with a SceneError naming the file, before any
    upload; one at the limit packs."""
    img = np.zeros((4, 4, 4), np.float32)
    scene = make_scene(
        [_triangle_mesh()],
        [Material("m", diffuse_texture=0)],
        images=[TextureImage("<img>", img)],
        textures=[TextureBinding(0)],
    )
    texels = 16 + 4 + 1  # the 4x4 image's chain: 4x4, 2x2, 1x1
    monkeypatch.setattr(upload, "MAX_TEXEL_FLOATS", 4 * texels)
    packed, _ = upload.pack_textures(scene)
    assert packed.shape == (texels, 4)
    monkeypatch.setattr(upload, "MAX_TEXEL_FLOATS", 4 * texels - 1)
    with pytest.raises(SceneError, match=rf"^{re.escape(scene.path)}: .*{texels} texels.*32-bit texel indices"):
        upload.pack_textures(scene)


def _sample_at_lods(ds: DeviceScene, device: str, uv: np.ndarray, lods: np.ndarray) -> np.ndarray:
    out = wp.zeros(len(uv), dtype=wp.vec4, device=device)
    wp.launch(
        _sample_lod,
        dim=len(uv),
        inputs=[
            ds.gpu,
            0,
            wp.array(uv.astype(np.float32), dtype=wp.vec2, device=device),
            wp.array(lods.astype(np.float32), dtype=float, device=device),
            out,
        ],
        device=device,
    )
    return out.numpy()


@pytest.mark.parametrize("wrap_s,wrap_t", WRAP_PAIRS)
def test_sample_texture_lod_filters_between_levels(device: str, wrap_s: Wrap, wrap_t: Wrap) -> None:
    """Integer lod L is bilinear in level L; a fraction blends L and L + 1 linearly
    (trilinear); lod past the chain clamps to its last level."""
    rng = np.random.default_rng(7)
    img = rng.random((16, 24, 4)).astype(np.float32)
    scale, bias = np.array([2.0, 1.0, 0.5, 1.0]), np.array([0.0, 0.1, 0.0, -0.5])
    scene = make_scene(
        [_triangle_mesh()],
        [Material("m", diffuse_texture=0)],
        images=[TextureImage("<img>", img)],
        textures=[TextureBinding(0, wrap_s, wrap_t, tuple(scale), tuple(bias))],
    )
    ds = DeviceScene(scene, device)
    chain = mip_chain(img)
    uv = rng.uniform(-1.2, 2.3, (64, 2))
    ref = [_ref_sample(level, uv, wrap_s, wrap_t, scale, bias) for level in chain]
    for lod in (1.0, 2.0, 4.0, 7.5):
        got = _sample_at_lods(ds, device, uv, np.full(len(uv), lod))
        np.testing.assert_allclose(got, ref[min(int(lod), len(chain) - 1)], atol=2e-5, err_msg=f"lod {lod}")
    for frac in (0.2, 0.5, 0.7):
        got = _sample_at_lods(ds, device, uv, np.full(len(uv), 1.0 + frac))
        np.testing.assert_allclose(got, (1.0 - frac) * ref[1] + frac * ref[2], atol=2e-5, err_msg=f"frac {frac}")


def test_magnified_lookups_are_plain_bilinear(device: str) -> None:
    """lod <= 0 (magnification) and a zero footprint give exactly the level-0 bilinear
    result of sample_texture / surface_at."""
    rng = np.random.default_rng(8)
    img = rng.random((8, 8, 4)).astype(np.float32)
    ds = DeviceScene(_texture_scene(img, [TextureBinding(0)]), device)
    uv = rng.uniform(0.0, 1.0, (40, 2)).astype(np.float32)
    plain = wp.zeros(len(uv), dtype=wp.vec4, device=device)
    uvs = wp.array(uv, dtype=wp.vec2, device=device)
    wp.launch(_sample, dim=len(uv), inputs=[ds.gpu, 0, uvs, plain], device=device)
    for lod in (-4.0, -0.5, 0.0):
        np.testing.assert_array_equal(_sample_at_lods(ds, device, uv, np.full(len(uv), lod)), plain.numpy())
    ref = _ref_sample(img, uv, Wrap.REPEAT, Wrap.REPEAT, np.ones(4), np.zeros(4))
    np.testing.assert_allclose(plain.numpy(), ref, atol=2e-5)

    textured = make_scene(
        [_triangle_mesh()],
        [Material("m", diffuse_texture=0)],
        images=[TextureImage("<img>", img)],
        textures=[TextureBinding(0)],
    )
    ds = DeviceScene(textured, device)
    bary = rng.uniform(0.0, 0.5, (20, 2)).astype(np.float32)
    for fp in ((0.0, 0.0, 0.0, 0.0), (0.05, 0.0, 0.0, 0.05)):  # zero; 0.4 texels per pixel
        out = wp.zeros(len(bary), dtype=SurfaceHit, device=device)
        ref = wp.zeros(len(bary), dtype=SurfaceHit, device=device)
        wp.launch(
            _surface_grad,
            dim=len(bary),
            inputs=[ds.gpu, wp.array(bary, dtype=wp.vec2, device=device), wp.vec4(*fp), out, ref],
            device=device,
        )
        np.testing.assert_array_equal(out.numpy()["albedo"], ref.numpy()["albedo"])


def test_texture_lod_is_log2_of_the_longer_pixel_axis(device: str) -> None:
    img = np.zeros((32, 64, 4), np.float32)
    ds = DeviceScene(_texture_scene(img, [TextureBinding(0)]), device)
    w, h = 64.0, 32.0
    fps = np.array(
        [
            [0.0, 0.0, 0.0, 0.0],
            [0.5 / w, 0.0, 0.0, 0.9 / h],  # magnified: below one texel per pixel
            [8.0 / w, 0.0, 0.0, 2.0 / h],  # 8 texels along x
            [3.0 / w, 4.0 / h, 0.0, -1.0 / h],  # |(3, 4)| = 5 texels
            [1.0 / w, 0.0, 10.0 / w, 6.0 / h],  # the y axis is longer: sqrt(136)
        ],
        np.float32,
    )
    out = wp.zeros(len(fps), dtype=float, device=device)
    wp.launch(_lod, dim=len(fps), inputs=[ds.gpu, 0, wp.array(fps, dtype=wp.vec4, device=device), out], device=device)
    got = out.numpy()
    assert got[0] <= 0.0 and got[1] <= 0.0
    np.testing.assert_allclose(got[2:], np.log2([8.0, 5.0, np.sqrt(136.0)]), atol=0.006)


def test_uv_footprint_is_the_derivative_of_the_plane_hit_uv(device: str) -> None:
    """Ray differentials against float64 central differences of the ray/plane hit's uv."""
    rng = np.random.default_rng(9)
    pts = np.array([[-1.0, -0.5, -3.0], [1.5, -0.2, -4.0], [0.1, 1.2, -3.5]], np.float32)
    uvs = np.array([[0.1, 0.1], [2.0, 0.3], [0.4, 1.7]], np.float32)
    scene = make_scene([MeshInput(pts, np.array([[0, 1, 2]], np.int32), 0, None, uvs)], [Material("m")])
    ds = DeviceScene(scene, device)
    origin = np.array([0.2, 0.1, 0.5])
    dirs = pts.mean(axis=0) + rng.uniform(-0.3, 0.3, (16, 3)) - origin
    ddx, ddy = np.array([0.01, 0.0, 0.002]), np.array([0.0, -0.01, 0.001])
    out = wp.zeros(len(dirs), dtype=wp.vec4, device=device)
    wp.launch(
        _footprint,
        dim=len(dirs),
        inputs=[
            ds.gpu,
            wp.vec3(*origin),
            wp.array(dirs.astype(np.float32), dtype=wp.vec3, device=device),
            wp.vec3(*ddx),
            wp.vec3(*ddy),
            out,
        ],
        device=device,
    )
    p = pts.astype(np.float64)
    n = np.cross(p[1] - p[0], p[2] - p[0])
    m = np.linalg.inv(np.stack([p[1] - p[0], p[2] - p[0], n], axis=1))

    def hit_uv(d: np.ndarray) -> np.ndarray:
        q = origin + d * (np.dot(p[0] - origin, n) / np.dot(d, n))
        b1, b2, _ = m @ (q - p[0])
        return uvs[0] + b1 * (uvs[1] - uvs[0]) + b2 * (uvs[2] - uvs[0])

    eps = 1e-3
    for k, d in enumerate(dirs.astype(np.float32).astype(np.float64)):
        gx = (hit_uv(d + eps * ddx) - hit_uv(d - eps * ddx)) / (2 * eps)
        gy = (hit_uv(d + eps * ddy) - hit_uv(d - eps * ddy)) / (2 * eps)
        np.testing.assert_allclose(out.numpy()[k], np.concatenate([gx, gy]), rtol=2e-3, atol=1e-6)
