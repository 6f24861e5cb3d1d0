"""Texture filtering at secondary hits (``trace/cone.py``): a texture seen in a mirror
reads its mip chain over the pixel's ray cone, as a direct view from the same path
length would."""

from __future__ import annotations

import numpy as np
from trace_kit import trace_variants

from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Material, TextureBinding, TextureImage

W, H = 64, 48
TEXELS = 64


def _emitting_image(checker: bool) -> np.ndarray:
    """TEXELS x TEXELS: a one-texel black and white checker, or all white (opaque)."""
    on = np.add.outer(np.arange(TEXELS), np.arange(TEXELS)) % 2 if checker else np.ones((TEXELS, TEXELS))
    rgb = np.repeat(on.astype(np.float32)[..., None], 3, axis=2)
    return np.concatenate([rgb, np.ones((TEXELS, TEXELS, 1), np.float32)], axis=2)


def _mirror_view(device: str, checker: bool) -> np.ndarray:
    """The traced image of a mirror at z = -4 (facing the camera at the origin, 90-degree
    horizontal view) that shows an 8 x 8 emitting quad at z = +4, behind the camera and
    facing the mirror: a path of 12 to it, so a pixel (1/32 rad) spans 0.375 = 3 texels
    there (level of detail log2 3 = 1.58)."""
    mirror = quad((-10.0, -10.0, -4.0), (20.0, 0.0, 0.0), (0.0, 20.0, 0.0), 0)
    screen = quad((4.0, -4.0, 4.0), (-8.0, 0.0, 0.0), (0.0, 8.0, 0.0), 1)
    materials = [
        Material("/mirror", diffuse=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.0),
        Material("/screen", diffuse=(0.0, 0.0, 0.0), roughness=1.0, emissive_texture=0),
    ]
    cam = look_at_camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), hfov_deg=90.0)
    scene = make_scene(
        [mirror, screen],
        materials,
        cameras=[cam],
        images=[TextureImage("<screen>", _emitting_image(checker))],
        textures=[TextureBinding(0)],
    )
    out = trace_variants(scene, cam, device, W, H)
    assert (out.triangle_id < 2).all()  # every pixel sees the mirror
    return out.color


def test_a_minified_texture_in_a_mirror_reads_its_mip_chain(device: str) -> None:
    """Pixel centres in the mirror land on texel centres of the checker, three texels
    apart, so level-0 lookups would alias it into a black and white checker of pixels;
    over the cone every pixel reads levels 1 and 2, exactly the mean: half of what the
    all-white screen gives through the same mirror."""
    # Where the unfolded pixel rays meet the screen: x = 12 ndc_x tan_x, y = 12 ndc_y tan_y.
    cols, rows = np.meshgrid(np.arange(24, 40) + 0.5, np.arange(16, 32) + 0.5)
    x = 12.0 * (2.0 * cols / W - 1.0)
    y = 12.0 * 0.75 * (1.0 - 2.0 * rows / H)
    texel_x = (4.0 - x) / 8.0 * TEXELS  # u = (4 - x) / 8 along the screen's first edge
    texel_y = (1.0 - (y + 4.0) / 8.0) * TEXELS  # v = (y + 4) / 8, row 0 at the top
    np.testing.assert_allclose(texel_x % 1.0, 0.5, atol=1e-9)
    np.testing.assert_allclose(texel_y % 1.0, 0.5, atol=1e-9)
    level0 = (np.floor(texel_x) + np.floor(texel_y)) % 2
    assert 0.4 < level0.mean() < 0.6 and set(np.unique(level0)) == {0.0, 1.0}

    checker = _mirror_view(device, checker=True)[16:32, 24:40]
    white = _mirror_view(device, checker=False)[16:32, 24:40]
    assert white.min() > 0.5  # the mirror passes most of the light
    np.testing.assert_allclose(checker / white, 0.5, atol=1e-5)
