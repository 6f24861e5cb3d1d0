"""The same image at any position and scale: shipped scenes and a generated one under
a USD root transform (cameras and lights included) against the untransformed stage
(issue 10, case 1), and the local frame that makes it so."""

from __future__ import annotations

import numpy as np
import pytest
from hard_kit import SCENES, render_file

from warp_hybrid import open_scene_source
from warp_hybrid.renderer import Renderer, RenderSettings
from warp_hybrid.scene.authoring import writer
from warp_hybrid.scene.authoring.builders import look_at_camera
from warp_hybrid.scene.authoring.transformed import write_transformed_stage
from warp_hybrid.scene.invariance import compare
from warp_hybrid.scene.local_frame import ORIGIN_GRID_NEARS, choose_origin

TRANSFORMS = [
    ((1.0e3, 0.0, 0.0), 1.0),
    ((0.0, 1.0e4, 1.0e4), 1.0),
    ((1.0e5, 1.0e5, -1.0e5), 1.0),
    ((0.0, 0.0, 0.0), 1.0e-3),
    ((0.0, 0.0, 0.0), 1.0e-2),
    ((0.0, 0.0, 0.0), 1.0e2),
    ((0.0, 0.0, 0.0), 1.0e3),
]
W, H = 64, 48


def _generated(path):
    """A sphere on a ground plate in front of a wall, lit by a sun and a rect light on the wall."""
    stage = writer.new_stage()
    mats = {
        "grey": writer.define_material(stage, "/World/Looks/Grey", diffuse=(0.6, 0.6, 0.6), roughness=0.6),
        "mirror": writer.define_material(
            stage, "/World/Looks/Mirror", diffuse=(0.9, 0.9, 0.9), metallic=1.0, roughness=0.0
        ),
    }
    ground = np.array([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], np.float32)
    wall = np.array([[-2, 0, -2], [-2, 2, -2], [2, 2, -2], [2, 0, -2]], np.float32)
    m = writer.define_mesh(stage, "/World/Geom/Ground", ground, [0, 3, 2, 1], face_vertex_counts=[4])
    writer.bind_material(m, mats["grey"])
    m = writer.define_mesh(stage, "/World/Geom/Wall", wall, [0, 3, 2, 1], face_vertex_counts=[4])
    writer.bind_material(m, mats["grey"])
    t, p = np.meshgrid(np.linspace(0, np.pi, 17), np.linspace(0, 2 * np.pi, 33), indexing="ij")
    sph = np.stack([np.sin(t) * np.cos(p), np.cos(t), -np.sin(t) * np.sin(p)], -1).reshape(-1, 3) * 0.5 + [0, 0.5, 0]
    faces = [(r * 33 + s, (r + 1) * 33 + s, (r + 1) * 33 + s + 1, r * 33 + s + 1) for r in range(16) for s in range(32)]
    m = writer.define_mesh(stage, "/World/Geom/Ball", sph, np.ravel(faces), face_vertex_counts=[4] * len(faces))
    writer.bind_material(m, mats["mirror"])
    writer.define_distant_light(stage, "/World/Lights/Sun", direction=(-0.4, -1.0, -0.3), intensity=2.0)
    writer.define_rect_light(
        stage, "/World/Lights/Panel", center=(0.0, 1.2, -2.0), direction=(0, 0, 1), width=0.6, height=0.4, intensity=4.0
    )
    writer.define_camera(stage, "/World/Cameras/Main", eye=(1.5, 1.4, 3.0), target=(0.0, 0.5, 0.0), hfov_deg=50.0)
    writer.save_stage(stage, path)
    return path


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    return _generated(tmp_path_factory.mktemp("gen") / "generated.usda")


def _source(name, generated):
    return generated if name == "generated" else SCENES / f"{name}.usda"


@pytest.fixture(scope="module")
def references(device, generated):
    return {n: render_file(_source(n, generated), device, W, H) for n in ("cornell_glass", "hard_cases", "generated")}


@pytest.mark.parametrize("name", ["cornell_glass", "hard_cases", "generated"])
@pytest.mark.parametrize("translate, scale", TRANSFORMS)
def test_transformed_stage_renders_the_same(device, tmp_path, references, generated, name, translate, scale):
    moved = write_transformed_stage(_source(name, generated), tmp_path / "moved.usda", translate, scale)
    out = render_file(moved, device, W, H)
    a = compare(references[name].view, out.view, scale)
    assert np.isfinite(out.view.depth).mean() == pytest.approx(np.isfinite(references[name].view.depth).mean())
    assert a.all >= 0.99, a
    assert a.interior <= 0.002 * a.pixels, a  # the rest only at silhouettes


def test_position_aov_is_local_plus_origin(device, tmp_path):
    """Geometry, cameras and lights live relative to ``Scene.origin``; adding it back in
    float64 gives the world positions of the stage (the README's position AOV)."""
    t = np.array([1.0e5, -3.0e4, 7.0e4])
    moved = write_transformed_stage(SCENES / "cornell_glass.usda", tmp_path / "m.usda", t, 1.0)
    scene = open_scene_source(moved).scene_at(None)
    ref = open_scene_source(SCENES / "cornell_glass.usda").scene_at(None)
    assert not ref.origin.any() and scene.origin.any()
    np.testing.assert_allclose(scene.points.astype(np.float64) + scene.origin, ref.points + t, rtol=0, atol=1e-5)
    np.testing.assert_allclose(scene.cameras[0].position + scene.origin, ref.cameras[0].position + t, atol=1e-9)
    np.testing.assert_allclose(
        np.add(scene.lights[0].position, scene.origin), np.add(ref.lights[0].position, t), atol=1e-9
    )
    back = render_file(SCENES / "cornell_glass.usda", device, W, H)
    hit = back.triangle_id >= 0
    with Renderer(scene, RenderSettings(width=W, height=H, device=device, mode="raster")) as r:
        frame = r.render(scene.cameras[0])
        local = frame.gbuffer.channel_numpy("position")
        aov = frame.aovs()["position"]
    # On the device: local hit points, precise to float32 of their small local values.
    world = local[hit].astype(np.float64) + scene.origin
    np.testing.assert_allclose(world, back.position[hit].astype(np.float64) + t, atol=1e-4)
    # The AOV is world space: the float32 of that sum (ulps of 0.008 at 1e5), NaN on background.
    np.testing.assert_allclose(aov[hit], world, rtol=0, atol=0.01)
    assert np.isnan(aov[~hit]).all()


@pytest.mark.parametrize("offset", [0.0, 1.0e3, 1.0e5, -3.7e6])
@pytest.mark.parametrize("near", [1.0e-5, 0.01, 1.0])
def test_origin_keeps_the_camera_within_half_a_grid_step(offset, near):
    cam = look_at_camera((offset + 0.3, 1.0, 4.0), (offset, 0.0, 0.0), near=near)
    o = choose_origin(cam)
    q = 2.0 ** np.ceil(np.log2(ORIGIN_GRID_NEARS * near))
    assert np.all(np.abs(cam.position - o) <= q / 2) and np.all(np.mod(o, q) == 0)
    if abs(offset) + 4.0 < q / 2:
        assert not o.any()  # scenes near the world origin keep the world frame


def test_scaled_camera_clips_at_its_scaled_range(tmp_path):
    """USD's frustum semantics: the clipping range scales with the camera's transform."""
    moved = write_transformed_stage(SCENES / "cornell_glass.usda", tmp_path / "s.usda", (0, 0, 0), 1.0e-3)
    cam = open_scene_source(moved).scene_at(None).cameras[0]
    ref = open_scene_source(SCENES / "cornell_glass.usda").scene_at(None).cameras[0]
    assert (cam.near, cam.far) == pytest.approx((ref.near * 1e-3, ref.far * 1e-3), rel=1e-6)
    assert cam.tan_half_fov_x == pytest.approx(ref.tan_half_fov_x, rel=1e-9)
