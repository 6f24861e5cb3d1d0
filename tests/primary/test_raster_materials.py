"""Texture orientation and alpha cut-outs through both primary paths."""

from __future__ import annotations

import numpy as np
import pytest

from warp_hybrid.scene.authoring.builders import MeshInput, make_scene, quad
from warp_hybrid.scene.model import Camera, Material, Scene, TextureBinding, TextureImage, Wrap

W, H = 64, 48


def _camera() -> Camera:
    """At the origin looking down -Z, tan(half hfov) = 1: the 2x2 quad at depth 2
    spans screen x in [16, 48] and y in [8, 40]."""
    return Camera("/cam", np.eye(4), 50.0, 100.0, 75.0, 0.05, 1.0e4)


def _front_quad(material: int) -> MeshInput:
    """Corner at the bottom-left, u to the right, v up: uv (0, 1) is the top-left."""
    return quad((-1.0, -1.0, -2.0), (2.0, 0.0, 0.0), (0.0, 2.0, 0.0), material)


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_texture_top_left_texel_shows_at_the_top_left(device: str, path: str, render) -> None:
    red, green, blue, white = (1, 0, 0, 1), (0, 1, 0, 1), (0, 0, 1, 1), (1, 1, 1, 1)
    img = np.array([[red, green], [blue, white]], np.float32)  # row 0 = top of the image
    scene = make_scene(
        [_front_quad(0)],
        [Material("tex", diffuse_texture=0)],
        images=[TextureImage("<2x2>", img)],
        textures=[TextureBinding(0, Wrap.CLAMP, Wrap.CLAMP)],
    )
    albedo = render(scene, _camera(), W, H, device, path).albedo.numpy()
    # Quarter-way into each quadrant the bilinear filter (clamped) returns a pure texel.
    np.testing.assert_allclose(albedo[10, 18], red[:3], atol=1e-5)
    np.testing.assert_allclose(albedo[10, 45], green[:3], atol=1e-5)
    np.testing.assert_allclose(albedo[37, 18], blue[:3], atol=1e-5)
    np.testing.assert_allclose(albedo[37, 45], white[:3], atol=1e-5)


def _cutout_scene(front: Material, images: list[TextureImage]) -> Scene:
    back = quad((-4.0, -4.0, -3.0), (8.0, 0.0, 0.0), (0.0, 8.0, 0.0), 1)
    return make_scene(
        [_front_quad(0), back],
        [front, Material("back")],
        images=images,
        textures=[TextureBinding(0, Wrap.CLAMP, Wrap.CLAMP)] if images else [],
    )


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_cutout_checker_shows_the_back_plane_through_holes(device: str, path: str, render) -> None:
    """A 4x4 checker in alpha (texel (r, c) opaque when r + c is odd), threshold 0.5."""
    alpha = (np.add.outer(np.arange(4), np.arange(4)) % 2).astype(np.float32)
    img = np.concatenate([np.ones((4, 4, 3), np.float32), alpha[..., None]], axis=-1)
    front = Material("leaf", opacity_texture=0, opacity_channel=3, opacity_threshold=0.5)
    gb = render(_cutout_scene(front, [TextureImage("<checker>", img)]), _camera(), W, H, device, path)
    tri = gb.triangle_id.numpy()
    depth = gb.depth.numpy()
    for r in range(4):
        for c in range(4):
            y, x = 12 + 8 * r, 20 + 8 * c  # pixel nearest to texel (r, c)'s centre
            if alpha[r, c] > 0.5:
                assert tri[y, x] in (0, 1) and depth[y, x] == pytest.approx(2.0, rel=1e-5)
            else:
                assert tri[y, x] in (2, 3) and depth[y, x] == pytest.approx(3.0, rel=1e-5)


@pytest.mark.parametrize("path", ["raster", "raycast"])
def test_constant_opacity_below_threshold_cuts_the_whole_surface(device: str, path: str, render) -> None:
    front = Material("ghost", opacity=0.2, opacity_threshold=0.5)
    tri = render(_cutout_scene(front, []), _camera(), W, H, device, path).triangle_id.numpy()
    assert set(np.unique(tri)) == {2, 3}
