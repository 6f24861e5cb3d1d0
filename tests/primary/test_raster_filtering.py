"""Texture filtering in the G-buffer: minified textures read their mip chain at the
pixel's footprint (same in both primary paths), magnified ones stay bilinear."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Camera, Material, TextureBinding, TextureImage

W, H = 64, 48


def _checker(n: int) -> np.ndarray:
    """n x n texels alternating black and white (opaque)."""
    on = (np.add.outer(np.arange(n), np.arange(n)) % 2).astype(np.float32)
    return np.concatenate([np.repeat(on[..., None], 3, axis=2), np.ones((n, n, 1), np.float32)], axis=2)


def _front_camera() -> Camera:
    """At the origin looking down -Z, tan(half hfov) = 1: a pixel is z / 32 wide at depth z."""
    return Camera("/cam", np.eye(4), 50.0, 100.0, 75.0, 0.05, 1.0e4)


def _unfiltered(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Level-0 bilinear lookup (repeat) at uv: what sampling without mips would return."""
    n = img.shape[0]
    x = np.mod(uv[:, 0], 1.0) * n - 0.5
    y = np.mod(1.0 - uv[:, 1], 1.0) * n - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]

    def t(c: np.ndarray, r: np.ndarray) -> np.ndarray:
        return img[np.mod(r, n), np.mod(c, n), :3]

    top = t(x0, y0) * (1 - fx) + t(x0 + 1, y0) * fx
    bottom = t(x0, y0 + 1) * (1 - fx) + t(x0 + 1, y0 + 1) * fx
    return top * (1 - fy) + bottom * fy


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_minified_checker_averages_to_grey(device: str, path: str, render) -> None:
    """A 56 x 56 one-texel checker on a 2 x 2 quad at depth 8 covers 8 x 8 pixels (7
    texels per pixel, level of detail 2.8): every pixel reads the mean, 0.5, where
    level-0 sampling (pixel centres on texel centres) aliases to 0 or 1."""
    img = _checker(56)
    scene = make_scene(
        [quad((-1.0, -1.0, -8.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), 0)],
        [Material("checker", diffuse_texture=0)],
        images=[TextureImage("<checker>", img)],
        textures=[TextureBinding(0)],
    )
    albedo = render(scene, _front_camera(), W, H, device, path).albedo.numpy()
    # The quad spans pixel columns 28..35 and rows 20..27; keep the 6 x 6 interior.
    inner = albedo[21:27, 29:35]
    np.testing.assert_allclose(inner, 0.5, atol=1e-4)
    # Sanity check of the set-up: level 0 at these pixel centres is far from grey.
    cols, rows = np.meshgrid(np.arange(29, 35) + 0.5, np.arange(21, 27) + 0.5)
    uv = np.stack([(cols.ravel() - 28.0) / 8.0, 1.0 - (rows.ravel() - 20.0) / 8.0], axis=1)
    np.testing.assert_allclose(np.abs(_unfiltered(img, uv) - 0.5), 0.5, atol=1e-6)


def test_oblique_textured_floor_agrees_between_paths_and_fades_to_grey(device: str, render) -> None:
    """A checker floor seen at a grazing angle: both paths pick the same levels (same
    footprint), near texels keep their contrast and the distance averages to grey."""
    img = _checker(32)
    floor = quad((-20.0, 0.0, 4.0), (40.0, 0.0, 0.0), (0.0, 0.0, -60.0), 0)
    scene = make_scene(
        [floor],
        [Material("floor", diffuse_texture=0)],
        images=[TextureImage("<checker>", img)],
        textures=[TextureBinding(0, scale=(1.0, 1.0, 1.0, 1.0))],
    )
    cam = look_at_camera((0.0, 1.0, 3.0), (0.0, 0.0, -6.0), hfov_deg=60.0)
    a = render(scene, cam, 96, 72, device, "raster")
    b = render(scene, cam, 96, 72, device, "raycast")
    same = (a.triangle_id.numpy() == b.triangle_id.numpy()) & (a.triangle_id.numpy() >= 0)
    assert same.mean() > 0.5
    albedo = a.albedo.numpy()[..., 0]
    np.testing.assert_allclose(albedo[same], b.albedo.numpy()[..., 0][same], atol=1e-4)
    depth = a.depth.numpy()
    far = same & (depth > 25.0)
    near = same & (depth < 6.0)
    assert far.sum() > 20 and near.sum() > 200
    np.testing.assert_allclose(albedo[far], 0.5, atol=0.02)
    assert albedo[near].min() < 0.2 and albedo[near].max() > 0.8
