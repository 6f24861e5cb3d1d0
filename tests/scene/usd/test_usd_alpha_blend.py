"""Alpha blending (UsdPreviewSurface opacity < 1 with threshold 0 and no glass optics):
which materials blend, and a 50%-alpha quad over a red quad shows half red in every mode."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from pxr import Sdf
from render_kit import add_camera
from usd_stage_kit import add_mesh, bind, new_stage, preview_material, save_and_load, set_st, st_reader, uv_texture

from warp_hybrid import Renderer, RenderSettings
from warp_hybrid.scene.model import Scene

W, H = 48, 36
BLACK = (0.0, 0.0, 0.0)


def _material_named(scene: Scene, suffix: str):
    return next(m for m in scene.materials if m.name.endswith(suffix))


def _square(stage, path: str, half: float, z: float):
    """A square facing +Z, centred on the axis."""
    h = half
    return add_mesh(stage, path, [(-h, -h, z), (h, -h, z), (h, h, z), (-h, h, z)], [4], [0, 1, 2, 3])


def _cover_scene(tmp_path: Path, alpha: float, **front_inputs) -> Scene:
    """A red emitter (2 x 2, z = -0.5) behind a black 1 x 1 quad of opacity ``alpha``
    (z = 0), neither reflecting any light (specular workflow, black specular), seen
    from z = 3; ``front_inputs`` are more inputs of the front quad's surface."""
    stage, path = new_stage(tmp_path)
    add_camera(stage, 3.0)
    dark = dict(diffuseColor=BLACK, useSpecularWorkflow=1, specularColor=BLACK, roughness=1.0)
    red, _ = preview_material(stage, "/World/Looks/Red", emissiveColor=(1.0, 0.0, 0.0), **dark)
    front, surface = preview_material(stage, "/World/Looks/Front", opacity=alpha, **dark)
    for name, (type_name, value) in front_inputs.items():
        surface.CreateInput(name, type_name).Set(value)
    bind(_square(stage, "/World/Back", 1.0, -0.5), red)
    bind(_square(stage, "/World/Front", 0.5, 0.0), front)
    return save_and_load(stage, path)


def _color(scene: Scene, mode: str) -> np.ndarray:
    """Linear colour of one frame (hybrid: the whole screen traced)."""
    settings = RenderSettings(
        width=W, height=H, mode=mode, window_fraction=1.0, feather_px=0.0, antialias=False, exposure_ev=0.0
    )
    with Renderer(scene, settings) as renderer:
        frame = renderer.render(scene.cameras[0])
        return frame.color, frame.aovs()["depth"]


def test_opacity_without_glass_optics_is_alpha_blending(tmp_path: Path) -> None:
    """No ior / thinWalled / attenuation: coverage; an authored ior: glass; opacityMode
    presence: coverage whatever else is authored; a threshold: a cut-out, not blended."""
    stage, path = new_stage(tmp_path)
    looks = {
        "Plain": dict(opacity=0.5),
        "Glass": dict(opacity=0.5, ior=1.5),
        "Cutout": dict(opacity=0.5, opacityThreshold=0.25),
    }
    for i, (name, inputs) in enumerate(looks.items()):
        mat, _ = preview_material(stage, f"/World/Looks/{name}", **inputs)
        bind(_square(stage, f"/World/{name}", 0.5, -float(i)), mat)
    presence, surface = preview_material(stage, "/World/Looks/Presence", opacity=0.5, ior=1.5)
    surface.CreateInput("opacityMode", Sdf.ValueTypeNames.Token).Set("presence")
    bind(_square(stage, "/World/PresenceQuad", 0.5, -4.0), presence)
    scene = save_and_load(stage, path)
    plain, glass = _material_named(scene, "Plain"), _material_named(scene, "Glass")
    cutout, presence_m = _material_named(scene, "Cutout"), _material_named(scene, "Presence")
    assert plain.is_blended and not plain.is_glass and not plain.is_refractive
    assert glass.is_glass and glass.is_refractive and not glass.is_blended
    assert presence_m.is_blended and not presence_m.is_refractive
    assert cutout.is_cutout and not cutout.is_blended and not cutout.is_transmissive


@pytest.mark.parametrize("mode", ["raster", "hybrid", "full"])
def test_half_alpha_quad_over_red_shows_half_red(tmp_path: Path, mode: str) -> None:
    """Coverage 0.5 of a surface that sends no light over a red emitter of radiance 1:
    0.5 red where they overlap (the raster layer through its second visibility layer,
    the traced one by a ray straight through), 1 beside it; the depth AOV is the front
    quad's."""
    scene = _cover_scene(tmp_path, 0.5)
    color, depth = _color(scene, mode)
    centre = color[H // 2 - 4 : H // 2 + 4, W // 2 - 4 : W // 2 + 4].reshape(-1, 3)
    np.testing.assert_allclose(centre, np.tile([0.5, 0.0, 0.0], (len(centre), 1)), atol=1e-5)
    assert np.allclose(depth[H // 2, W // 2], 3.0, rtol=1e-5)
    # Beside the front quad (|x| in (0.5, 1) at z = -0.5 seen from z = 3): red at full radiance.
    tan_x = 0.36
    x = ((np.arange(W) + 0.5) / W * 2 - 1) * tan_x * 3.5
    beside = (np.abs(x) > 0.5 * 3.5 / 3.0 + 0.05) & (np.abs(x) < 0.95)
    np.testing.assert_allclose(color[H // 2, beside], np.tile([1.0, 0.0, 0.0], (int(beside.sum()), 1)), atol=1e-5)


@pytest.mark.parametrize("mode", ["raster", "full"])
def test_glass_of_the_same_opacity_tints_instead(tmp_path: Path, mode: str) -> None:
    """With an authored ior the same quad is glass: what passes is tinted by its (black)
    colour, so the red behind it is gone."""
    scene = _cover_scene(tmp_path, 0.5, ior=(Sdf.ValueTypeNames.Float, 1.5))
    color, _ = _color(scene, mode)
    assert np.abs(color[H // 2 - 4 : H // 2 + 4, W // 2 - 4 : W // 2 + 4]).max() < 1e-6


@pytest.mark.parametrize("mode", ["raster", "full"])
def test_texels_of_alpha_zero_show_what_is_behind(tmp_path: Path, mode: str) -> None:
    """The front quad's opacity from a texture's alpha: 0 on the left half (the red
    behind shows whole), 1 on the right (the black quad hides it)."""
    rgba = np.zeros((8, 8, 4), np.uint8)
    rgba[:, 4:, 3] = 255
    assert cv2.imwrite(str(tmp_path / "alpha.png"), rgba)
    stage, path = new_stage(tmp_path)
    add_camera(stage, 3.0)
    dark = dict(diffuseColor=BLACK, useSpecularWorkflow=1, specularColor=BLACK, roughness=1.0)
    red, _ = preview_material(stage, "/World/Looks/Red", emissiveColor=(1.0, 0.0, 0.0), **dark)
    front, surface = preview_material(stage, "/World/Looks/Front", **dark)
    alpha = uv_texture(stage, "/World/Looks/Front/Tex", "alpha.png", st_reader(stage, "/World/Looks/Front/St"), "a")
    surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(alpha)
    bind(_square(stage, "/World/Back", 1.0, -0.5), red)
    quad = _square(stage, "/World/Front", 0.5, 0.0)
    set_st(quad, [(0, 0), (1, 0), (1, 1), (0, 1)])
    bind(quad, front)
    scene = save_and_load(stage, path)
    assert _material_named(scene, "Front").is_blended
    color, _ = _color(scene, mode)
    row = color[H // 2]
    left, right = slice(W // 2 - 6, W // 2 - 2), slice(W // 2 + 2, W // 2 + 6)
    np.testing.assert_allclose(row[left], np.tile([1.0, 0.0, 0.0], (4, 1)), atol=1e-5)
    assert np.abs(row[right]).max() < 1e-6


def test_opaque_scene_has_no_alpha_layer(tmp_path: Path) -> None:
    """The second visibility layer runs only where the scene has blended materials."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    opaque = _cover_scene(tmp_path / "a", 1.0)
    blended = _cover_scene(tmp_path / "b", 0.5)
    for scene, expected in ((opaque, False), (blended, True)):
        with Renderer(scene, RenderSettings(width=W, height=H, mode="raster")) as renderer:
            stats = renderer.render(scene.cameras[0]).stats
        assert ("alpha_layer" in stats["stages_ms"]) is expected
        assert ("blending" in stats["effects"]) is expected
